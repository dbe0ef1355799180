/* ======================================================================
   Layer 2: kd-tree
   ====================================================================== */

#define SQFFD__KD_LEAF_SIZE 10u /* a node with more points than this is split */
#define SQFFD__KD_MIN_CHILD 5u  /* ... into children of at least this many points */

/* Nodes for n points: every leaf but a lone root holds >= MIN_CHILD points. */
static size_t sqffd__kd_max_nodes(size_t n)
{
    return n <= SQFFD__KD_LEAF_SIZE ? 1 : 2 * (n / SQFFD__KD_MIN_CHILD) - 1;
}

/* The one workspace layout: the permutation, then the nodes. */
static void sqffd__kd_layout(sqffd__arena *a, size_t n, uint32_t **index, sqffd_kdtree_node **nodes)
{
    *index = (uint32_t *)sqffd__arena_take(a, n, sizeof(uint32_t));
    *nodes = (sqffd_kdtree_node *)sqffd__arena_take(a, sqffd__kd_max_nodes(n), sizeof(sqffd_kdtree_node));
}

SQFFD_DEF size_t sqffd_kdtree_workspace_size(size_t n)
{
    sqffd__arena a;
    uint32_t *index;
    sqffd_kdtree_node *nodes;
    if (n == 0 || n > (size_t)UINT32_MAX) return 0;
    sqffd__arena_init(&a, NULL, 0);
    sqffd__kd_layout(&a, n, &index, &nodes);
    return sqffd__arena_required(&a);
}

/* ceil(log2(c)) for c >= 1: the depth a median-split subtree of c points needs. */
static unsigned sqffd__kd_log2_ceil(size_t c)
{
    unsigned bits = 0;
    size_t v = c - 1;
    while (v) { bits++; v >>= 1; }
    return bits;
}

/* Grows box ([0] = min corner, [1] = max corner) to hold p. */
static void sqffd__kd_extend(double box[2][3], const double *p)
{
    int d;
    for (d = 0; d < 3; d++) { /* conditional moves, not branches */
        box[0][d] = p[d] < box[0][d] ? p[d] : box[0][d];
        box[1][d] = p[d] > box[1][d] ? p[d] : box[1][d];
    }
}

static void sqffd__kd_empty_box(double box[2][3])
{
    int d;
    for (d = 0; d < 3; d++) { box[0][d] = HUGE_VAL; box[1][d] = -HUGE_VAL; }
}

/* Tight bounding box of the points index[begin..end). */
static void sqffd__kd_bounds(const double *points, const uint32_t *index, size_t begin, size_t end,
                             double box[2][3])
{
    size_t i;
    sqffd__kd_empty_box(box);
    for (i = begin; i < end; i++) sqffd__kd_extend(box, points + 3 * (size_t)index[i]);
}

/* Moves index[begin..end) so that position t holds the element of rank t
   along axis, smaller-or-equal ones before it, larger-or-equal after.
   Quickselect with Hoare partitions around a pivot at a pseudo-random
   position (a fixed xorshift sequence: deterministic, yet no ordering of the
   input makes it quadratic short of being built against that sequence). */
static void sqffd__kd_select(const double *points, uint32_t *index, size_t begin, size_t end,
                             size_t t, int axis)
{
    ptrdiff_t lo = (ptrdiff_t)begin, hi = (ptrdiff_t)end - 1, target = (ptrdiff_t)t;
    uint32_t random = 2463534242u;
    while (lo < hi) {
        double pivot;
        random ^= random << 13; random ^= random >> 17; random ^= random << 5;
        pivot = points[3 * (size_t)index[lo + (ptrdiff_t)(random % (uint32_t)(hi - lo + 1))] + (size_t)axis];
        ptrdiff_t i = lo, j = hi;
        while (i <= j) {
            uint32_t tmp;
            while (points[3 * (size_t)index[i] + (size_t)axis] < pivot) i++;
            while (points[3 * (size_t)index[j] + (size_t)axis] > pivot) j--;
            if (i > j) break;
            tmp = index[i]; index[i] = index[j]; index[j] = tmp;
            i++; j--;
        }
        if (target <= j) hi = j;
        else if (target >= i) lo = i;
        else break;
    }
}

/* A node waiting to be built: its point range, depth, tight box, and the
   node whose high child it is (0 for a low child or the root: those are
   simply the next node). */
typedef struct sqffd__kd_pending {
    size_t begin, end;
    unsigned depth;
    uint32_t parent_of_high;
    double box[2][3];
} sqffd__kd_pending;

/* Splits index[begin..end) of a node with a positive extent on `axis`: at the
   middle of the box (or the median), moved where needed so both children get
   MIN_CHILD points. Returns the size of the low part; fills both children's
   tight boxes. */
static size_t sqffd__kd_split(const double *points, uint32_t *index, const sqffd__kd_pending *node,
                              int axis, int median, double low_box[2][3], double high_box[2][3])
{
    size_t count = node->end - node->begin, low_count = count / 2;
    int by_rank = median; /* the low part is the low_count smallest on axis */
    if (!median) {
        /* Branch-free partition (every step swaps; only the boundary k moves
           by the comparison), so the point loads never wait on a branch. */
        double cut = 0.5 * node->box[0][axis] + 0.5 * node->box[1][axis]; /* cannot overflow */
        size_t i, k = node->begin;
        for (i = node->begin; i < node->end; i++) {
            uint32_t p = index[i];
            index[i] = index[k];
            index[k] = p;
            k += (size_t)(points[3 * (size_t)p + (size_t)axis] < cut);
        }
        low_count = k - node->begin;
        by_rank = low_count < SQFFD__KD_MIN_CHILD || count - low_count < SQFFD__KD_MIN_CHILD;
        if (by_rank) low_count = low_count < SQFFD__KD_MIN_CHILD ? SQFFD__KD_MIN_CHILD : count - SQFFD__KD_MIN_CHILD;
    }
    if (by_rank) sqffd__kd_select(points, index, node->begin, node->end, node->begin + low_count, axis);
    sqffd__kd_bounds(points, index, node->begin, node->begin + low_count, low_box);
    sqffd__kd_bounds(points, index, node->begin + low_count, node->end, high_box);
    return low_count;
}

SQFFD_DEF sqffd_result sqffd_kdtree_build(sqffd_kdtree *tree, const double *points, size_t n,
                                          void *workspace, size_t workspace_size)
{
    sqffd__arena a;
    uint32_t *index;
    sqffd_kdtree_node *nodes;
    sqffd__kd_pending stack[SQFFD_KDTREE_MAX_DEPTH + 1];
    size_t top = 0, node_count = 0, i;

    if (tree) memset(tree, 0, sizeof *tree);
    if (!tree || !points || !workspace || n == 0) return SQFFD_ERROR_INVALID_ARGUMENT;
    if (n > (size_t)UINT32_MAX) return SQFFD_ERROR_TOO_LARGE;
    sqffd__arena_init(&a, workspace, workspace_size);
    sqffd__kd_layout(&a, n, &index, &nodes);
    if (a.overflow) return SQFFD_ERROR_WORKSPACE_TOO_SMALL;

    sqffd__kd_empty_box(stack[0].box);
    for (i = 0; i < n; i++) {
        if (!sqffd__finite3(points + 3 * i)) return SQFFD_ERROR_NON_FINITE;
        sqffd__kd_extend(stack[0].box, points + 3 * i);
        index[i] = (uint32_t)i;
    }
    stack[0].begin = 0;
    stack[0].end = n;
    stack[0].depth = 0;
    stack[0].parent_of_high = 0;
    memcpy(tree->bbox, stack[0].box, sizeof tree->bbox);
    top = 1;
    while (top > 0) {
        sqffd__kd_pending cur = stack[--top];
        sqffd_kdtree_node *node = &nodes[node_count];
        size_t count = cur.end - cur.begin, low_count;
        double extent = -1.0;
        int axis = 0, d, median;

        SQFFD_ASSERT(node_count < sqffd__kd_max_nodes(n));
        memset(node, 0, sizeof *node); /* no stale bytes: equal inputs give equal trees */
        if (cur.parent_of_high) nodes[cur.parent_of_high - 1].high_child = (uint32_t)node_count;
        node_count++;
        for (d = 0; d < 3; d++) {
            double e = cur.box[1][d] - cur.box[0][d];
            if (e > extent) { extent = e; axis = d; }
        }
        if (count <= SQFFD__KD_LEAF_SIZE || !(extent > 0.0)) { /* small, or all points identical */
            node->u.leaf.begin = (uint32_t)cur.begin;
            node->u.leaf.end = (uint32_t)cur.end;
            node->axis = SQFFD_KDTREE_LEAF;
            continue;
        }
        /* Midpoint cuts while they cannot break the depth bound, else the
           median, whose subtree needs only ceil(log2(count)) more levels. */
        median = cur.depth + 1 + sqffd__kd_log2_ceil(count) > SQFFD_KDTREE_MAX_DEPTH;
        SQFFD_ASSERT(top + 2 <= SQFFD_KDTREE_MAX_DEPTH + 1);
        low_count = sqffd__kd_split(points, index, &cur, axis, median, stack[top + 1].box, stack[top].box);
        node->axis = (uint32_t)axis;
        node->u.split.low = stack[top + 1].box[1][axis];
        node->u.split.high = stack[top].box[0][axis]; /* high_child is set when that child is built */
        /* High child below the low one on the stack: the low child is built next. */
        stack[top].begin = cur.begin + low_count;
        stack[top].end = cur.end;
        stack[top].depth = cur.depth + 1;
        stack[top].parent_of_high = (uint32_t)node_count; /* this node's number + 1 */
        stack[top + 1].begin = cur.begin;
        stack[top + 1].end = cur.begin + low_count;
        stack[top + 1].depth = cur.depth + 1;
        stack[top + 1].parent_of_high = 0;
        top += 2;
    }
    tree->points = points;
    tree->count = n;
    tree->index = index;
    tree->nodes = nodes;
    tree->node_count = node_count;
    return SQFFD_OK;
}

/* ---- Queries --------------------------------------------------------------
   Results live in the caller's arrays as a max-heap on squared distance
   (the worst kept point on top), sorted once at the end. */
typedef struct sqffd__kd_results {
    size_t *index;
    double *dist2;
    size_t capacity, size;
    size_t within;  /* points seen at distance^2 <= reach (the radius count) */
    double reach;   /* points and subtrees farther than this (squared) cannot change the answer */
    int counting;   /* radius: every point within reach counts, so a full heap keeps reach */
} sqffd__kd_results;

static void sqffd__kd_sift_down(size_t *index, double *dist2, size_t size, size_t i)
{
    size_t moving = index[i];
    double d = dist2[i];
    for (;;) {
        size_t c = 2 * i + 1;
        if (c >= size) break;
        if (c + 1 < size && dist2[c + 1] > dist2[c]) c++;
        if (!(dist2[c] > d)) break;
        index[i] = index[c]; dist2[i] = dist2[c];
        i = c;
    }
    index[i] = moving; dist2[i] = d;
}

/* Keeps point (at squared distance d <= reach) if it is among the nearest
   `capacity` seen so far. */
static void sqffd__kd_offer(sqffd__kd_results *r, size_t point, double d)
{
    if (r->size < r->capacity) { /* not full: sift up from the end */
        size_t i = r->size++;
        while (i > 0 && r->dist2[(i - 1) / 2] < d) {
            r->index[i] = r->index[(i - 1) / 2]; r->dist2[i] = r->dist2[(i - 1) / 2];
            i = (i - 1) / 2;
        }
        r->index[i] = point; r->dist2[i] = d;
    } else if (r->size && d < r->dist2[0]) {
        r->index[0] = point; r->dist2[0] = d;
        sqffd__kd_sift_down(r->index, r->dist2, r->size, 0);
    } else {
        return;
    }
    if (!r->counting && r->size == r->capacity) r->reach = r->dist2[0];
}

/* Scans a leaf. A leaf bigger than the leaf size holds identical points only:
   one distance serves them all, and offering stops once it cannot be kept. */
static void sqffd__kd_scan_leaf(const sqffd_kdtree *tree, const sqffd_kdtree_node *leaf, const double q[3],
                                sqffd__kd_results *r)
{
    const uint32_t *index = tree->index;
    size_t i, begin = leaf->u.leaf.begin, end = leaf->u.leaf.end;
    if (end - begin > SQFFD__KD_LEAF_SIZE) {
        double d = sqffd__dist2_3(tree->points + 3 * (size_t)index[begin], q);
        if (!(d <= r->reach)) return;
        r->within += end - begin;
        for (i = begin; i < end && (r->size < r->capacity || (r->size && d < r->dist2[0])); i++)
            sqffd__kd_offer(r, index[i], d);
        return;
    }
    for (i = begin; i < end; i++) {
        double d = sqffd__dist2_3(tree->points + 3 * (size_t)index[i], q);
        if (d <= r->reach) {
            r->within++;
            sqffd__kd_offer(r, index[i], d);
        }
    }
}

/* Depth-first walk, nearest child first. sq0..sq2 hold the squared per-axis
   distances from the query to the region known to hold a subtree's points;
   their sum (added in the same order as a point's distance, so it never
   exceeds any of those points' computed distances) prunes the far child. */
static void sqffd__kd_search(const sqffd_kdtree *tree, const double q[3], sqffd__kd_results *r)
{
    struct { double sq[3]; double bound; uint32_t node; } stack[SQFFD_KDTREE_MAX_DEPTH];
    const sqffd_kdtree_node *nodes = tree->nodes;
    size_t top = 0;
    double sq0, sq1, sq2, off[3];
    uint32_t node = 0;
    int d;

    for (d = 0; d < 3; d++)
        off[d] = q[d] < tree->bbox[0][d] ? tree->bbox[0][d] - q[d]
               : q[d] > tree->bbox[1][d] ? q[d] - tree->bbox[1][d] : 0.0;
    sq0 = off[0] * off[0]; sq1 = off[1] * off[1]; sq2 = off[2] * off[2];
    if (!(sq0 + sq1 + sq2 <= r->reach)) return;
    for (;;) {
        const sqffd_kdtree_node *n = &nodes[node];
        if (n->axis != SQFFD_KDTREE_LEAF) {
            /* Branch-free step: the far child's entry is written in place
               and kept (top advances) only when it is within reach. */
            uint32_t axis = n->axis;
            double above_low = q[axis] - n->u.split.low, below_high = n->u.split.high - q[axis];
            int go_high = !(above_low < below_high);
            double gap = go_high ? above_low : below_high;
            SQFFD_ASSERT(top < SQFFD_KDTREE_MAX_DEPTH);
            stack[top].sq[0] = sq0; stack[top].sq[1] = sq1; stack[top].sq[2] = sq2;
            stack[top].sq[axis] = gap * gap;
            stack[top].bound = stack[top].sq[0] + stack[top].sq[1] + stack[top].sq[2];
            stack[top].node = go_high ? node + 1 : n->high_child;
            node = go_high ? n->high_child : node + 1;
            top += (size_t)(stack[top].bound <= r->reach);
            continue;
        }
        sqffd__kd_scan_leaf(tree, n, q, r);
        for (;;) { /* next pending subtree still within reach */
            if (top == 0) return;
            top--;
            if (stack[top].bound <= r->reach) break;
        }
        sq0 = stack[top].sq[0]; sq1 = stack[top].sq[1]; sq2 = stack[top].sq[2];
        node = stack[top].node;
    }
}

/* Sorts the heap by increasing distance. */
static void sqffd__kd_sort(sqffd__kd_results *r)
{
    size_t end = r->size;
    while (end > 1) {
        size_t i0 = r->index[0];
        double d0 = r->dist2[0];
        end--;
        r->index[0] = r->index[end]; r->dist2[0] = r->dist2[end];
        r->index[end] = i0; r->dist2[end] = d0;
        sqffd__kd_sift_down(r->index, r->dist2, end, 0);
    }
}

static size_t sqffd__kd_query(const sqffd_kdtree *tree, const double q[3], double limit, int counting,
                              size_t *indices, double *dist2, size_t capacity)
{
    sqffd__kd_results r;
    r.index = indices;
    r.dist2 = dist2;
    r.capacity = capacity;
    r.size = 0;
    r.within = 0;
    r.reach = limit;
    r.counting = counting;
    sqffd__kd_search(tree, q, &r);
    sqffd__kd_sort(&r);
    return counting ? r.within : r.size;
}

static int sqffd__kd_queryable(const sqffd_kdtree *tree, const double q[3])
{
    return tree && tree->count && tree->nodes && q && sqffd__finite3(q);
}

SQFFD_DEF size_t sqffd_kdtree_nearest(const sqffd_kdtree *tree, const double query[3], double *dist2)
{
    size_t nearest = 0;
    double d = NAN;
    if (sqffd__kd_queryable(tree, query)) sqffd__kd_query(tree, query, HUGE_VAL, 0, &nearest, &d, 1);
    if (dist2) *dist2 = d;
    return nearest;
}

SQFFD_DEF size_t sqffd_kdtree_knn(const sqffd_kdtree *tree, const double query[3], size_t k,
                                  size_t *indices, double *dist2)
{
    if (!sqffd__kd_queryable(tree, query) || !indices || !dist2 || k == 0) return 0;
    return sqffd__kd_query(tree, query, HUGE_VAL, 0, indices, dist2, k < tree->count ? k : tree->count);
}

SQFFD_DEF size_t sqffd_kdtree_radius(const sqffd_kdtree *tree, const double query[3], double radius,
                                     size_t *indices, double *dist2, size_t capacity)
{
    if (!sqffd__kd_queryable(tree, query) || !(radius >= 0.0)) return 0;
    if (!indices || !dist2) capacity = 0;
    return sqffd__kd_query(tree, query, radius * radius, 1, indices, dist2, capacity);
}

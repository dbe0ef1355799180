// Benchmark peer: nanoflann (KDTreeSingleIndexAdaptor, 3-D, double, L2_Simple_Adaptor,
// leaf size 10) behind plain C functions, so bench_kdtree.c can run the same data and
// queries through it. Built by `make bench` with g++ when /usr/include/nanoflann.hpp exists.
#include <nanoflann.hpp>
#include <cstddef>
#include <cstdint>

namespace {

struct Cloud {
    const double *points;
    size_t count;
    size_t kdtree_get_point_count() const { return count; }
    double kdtree_get_pt(uint32_t i, size_t dim) const { return points[3 * (size_t)i + dim]; }
    template <class Box> bool kdtree_get_bbox(Box &) const { return false; }
};

typedef nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Cloud>, Cloud, 3, uint32_t>
    Tree;

struct Peer {
    Cloud cloud;
    Tree *tree;
};

} // namespace

extern "C" {

// Builds the index over points (3 doubles each); the points must outlive it.
void *peer_nanoflann_build(const double *points, size_t n)
{
    Peer *p = new Peer;
    p->cloud.points = points;
    p->cloud.count = n;
    p->tree = new Tree(3, p->cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
    return p;
}

void peer_nanoflann_free(void *handle)
{
    Peer *p = static_cast<Peer *>(handle);
    delete p->tree;
    delete p;
}

// Bytes the index holds beyond the points (node pool and index permutation).
size_t peer_nanoflann_memory(void *handle)
{
    Peer *p = static_cast<Peer *>(handle);
    return p->tree->usedMemory(*p->tree);
}

// k nearest of each of nq queries: indices and squared distances, k per query.
void peer_nanoflann_knn(void *handle, const double *queries, size_t nq, size_t k, uint32_t *indices,
                        double *dist2)
{
    Peer *p = static_cast<Peer *>(handle);
    for (size_t i = 0; i < nq; i++)
        p->tree->knnSearch(queries + 3 * i, k, indices + k * i, dist2 + k * i);
}

} // extern "C"

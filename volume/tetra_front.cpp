#include "volume/tetra_front.h"

#include <cmath>
#include <cstring>
#include <limits>

#include <Eigen/Geometry>

namespace frontmesh::volume {

/// floor(4 log2 len) + kBuckets / 2, clamped, from len^2 = m 2^e (m in [0.5, 1)) without a
/// logarithm: 4 log2 len = 2 e + 2 log2 m, whose floor is 2 e - 1 for m >= 2^(-1/2) and
/// 2 e - 2 below. A length in bucket b is below 2^((b + 1 - kBuckets / 2) / 4).
inline int Front::bucket_of(double len2) {
    if (!(len2 > 0.0)) return 0;
    if (!(len2 < std::numeric_limits<double>::infinity())) return kBuckets - 1;
    // m and e as std::frexp gives them, from the bits of a normal len2 (the libm call was
    // a tenth of a front face update)
    std::uint64_t bits;
    std::memcpy(&bits, &len2, sizeof bits);
    const int biased = static_cast<int>(bits >> 52);  // sign bit 0
    int e = biased - 1022;
    double m;
    if (biased != 0) {
        bits = (bits & ((std::uint64_t{1} << 52) - 1)) | (std::uint64_t{1022} << 52);
        std::memcpy(&m, &bits, sizeof m);
    } else {
        m = std::frexp(len2, &e);  // subnormal
    }
    const int b = 2 * e - (m >= 0.70710678118654752 ? 1 : 2) + kBuckets / 2;
    return std::clamp(b, 0, kBuckets - 1);
}

Front::Front(const core::HugeVector<double>& xyz, const core::AdtBox& domain)
    : xyz_(xyz),
      node_adt_(domain, core::AdtItems::points),
      face_adt_(domain, core::AdtItems::boxes) {}

inline void Front::count_edge(std::int32_t u, std::int32_t v, int delta) {
    const int b = bucket_of((x(u) - x(v)).squaredNorm());
    edge_bucket_[b] += delta;
    if (delta > 0) {
        top_bucket_ = std::max(top_bucket_, b);
    } else {
        while (top_bucket_ > 0 && edge_bucket_[top_bucket_] == 0) --top_bucket_;
    }
}

double Front::max_edge() const {
    // per bucket, computed once for all fronts (read by every validity test)
    static const std::array<double, kBuckets> bound = [] {
        std::array<double, kBuckets> b{};
        for (int i = 0; i < kBuckets - 1; ++i)
            b[i] = std::exp2((i + 1 - kBuckets / 2) / 4.0) * 1.0001;
        b[kBuckets - 1] = std::numeric_limits<double>::infinity();
        return b;
    }();
    return bound[static_cast<std::size_t>(top_bucket_)];
}

std::int32_t Front::add_face(std::int32_t a, std::int32_t b, std::int32_t c) {
    std::int32_t f;
    if (!free_faces_.empty()) {
        f = free_faces_.back();
        free_faces_.pop_back();
    } else {
        f = static_cast<std::int32_t>(faces_.size());
        faces_.push_back({{0, 0, 0}, {-1, -1, -1}, {0.0, 0.0, 0.0}, 0.0, 0, -1});
        falive_.push_back(0);
        fprev_.insert(fprev_.end(), {-1, -1, -1});
    }
    faces_[f].v = {a, b, c};
    for (int k = 0; k < 3; ++k) count_edge(faces_[f].v[k], faces_[f].v[(k + 1) % 3], +1);
    const Eigen::Vector3d n = (x(b) - x(a)).cross(x(c) - x(a));
    const double len = n.norm();
    faces_[f].area = 0.5 * len;
    const Eigen::Vector3d u = len > 0.0 ? Eigen::Vector3d(n / len) : Eigen::Vector3d::Zero();
    faces_[f].n[0] = u.x();
    faces_[f].n[1] = u.y();
    faces_[f].n[2] = u.z();
    ++faces_[f].stamp;
    falive_[f] = 1;
    {
        core::AdtBox box;
        for (const std::int32_t v : {a, b, c}) box.extend(x(v));
        face_adt_.insert(f, box);
    }
    const Tri& t = faces_[f].v;
    for (int k = 0; k < 3; ++k) {
        if (face_head_[t[k]] < 0) node_adt_.insert(t[k], x(t[k]));  // joins the front
        const std::int32_t head = face_head_[t[k]];
        faces_[f].next[k] = head;
        fprev_[3 * f + k] = -1;
        if (head >= 0) fprev_[head] = 3 * f + k;
        face_head_[t[k]] = 3 * f + k;
    }
    ++size_;
    return f;
}

void Front::remove_face(std::int32_t f) {
    const Tri t = faces_[f].v;
    for (int k = 0; k < 3; ++k) {
        const std::int32_t prev = fprev_[3 * f + k], next = faces_[f].next[k];
        (prev < 0 ? face_head_[t[k]] : faces_[prev / 3].next[prev % 3]) = next;
        if (next >= 0) fprev_[next] = prev;
        if (face_head_[t[k]] < 0) node_adt_.remove(t[k]);  // leaves the front
        count_edge(t[k], t[(k + 1) % 3], -1);
    }
    falive_[f] = 0;
    face_adt_.remove(f);
    ++faces_[f].stamp;
    free_faces_.push_back(f);
    --size_;
}

}  // namespace frontmesh::volume

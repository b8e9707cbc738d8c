#include "volume/tet_validity.h"

#include <algorithm>
#include <limits>

#include <Eigen/Core>
#include <Eigen/Geometry>

#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "pipeline/core/predicates.h"

namespace frontmesh::volume {

namespace {

using V3 = Eigen::Vector3d;

// The tet's four faces as (three nodes, opposite node) over (a, b, c, q) = (0, 1, 2, 3):
// the base, then the three faces (a, b, q), (b, c, q), (c, a, q) a candidate may add. The
// sign of orient3d of a permutation of (a, b, c, q) is that of orient3d(a, b, c, q) = -1
// times its parity (exact signs obey it exactly): for the identity -1; for one swap and the
// two odd 4-cycles below, +1. A point w is in the closed tet when orient3d(face i, w) is 0 or
// kInside[i] for every i.
constexpr int kF[4][4] = {{0, 1, 2, 3}, {0, 1, 3, 2}, {1, 2, 3, 0}, {2, 0, 3, 1}};
constexpr int kInside[4] = {-1, 1, 1, 1};
// The planes through tet node j (bits 10-13 of its code): every plane but the one opposite.
constexpr std::uint16_t kOnPlanes[4] = {0b1011, 0b0111, 0b1101, 0b1110};

/// The tet's box and its outward face planes n . x = d, with a tolerance on n . x - d far
/// above its rounding error for every point within `max_edge` of the box.
struct TetPlanes {
    double lo[3], hi[3];
    V3 pn[4];
    double pd[4], ptol[4];

    TetPlanes(const FrontView& front, const std::array<std::int32_t, 4>& tv) {
        auto x = [&](std::int32_t v) { return V3(front.p(v)[0], front.p(v)[1], front.p(v)[2]); };
        const double *a = front.p(tv[0]), *b = front.p(tv[1]), *c = front.p(tv[2]),
                     *q = front.p(tv[3]);
        for (int k = 0; k < 3; ++k) {
            lo[k] = std::min({a[k], b[k], c[k], q[k]});
            hi[k] = std::max({a[k], b[k], c[k], q[k]});
        }
        const double diam =
            (V3(hi[0], hi[1], hi[2]) - V3(lo[0], lo[1], lo[2])).norm() + front.max_edge;
        const double scale = diam + V3(a[0], a[1], a[2]).cwiseAbs().maxCoeff();
        for (int i = 0; i < 4; ++i) {
            const V3 A = x(tv[kF[i][0]]), B = x(tv[kF[i][1]]), C = x(tv[kF[i][2]]);
            pn[i] = (B - A).cross(C - A);
            if (pn[i].dot(x(tv[kF[i][3]]) - A) > 0.0) pn[i] = -pn[i];
            pd[i] = pn[i].dot(A);
            ptol[i] = 1e-9 * pn[i].norm() * scale;
        }
    }
};

/// A node's code in plain code: bits 0-2 below lo on x, y, z, bits 3-5 above hi, bit 6 + i
/// beyond plane i by more than its tolerance, ((n_x x + n_y y) + n_z z) - d > tol.
struct PortableCoder {
    const TetPlanes& t;
    explicit PortableCoder(const TetPlanes& planes) : t(planes) {}
    unsigned operator()(const double* pw) const {
        unsigned c = 0;
        for (int k = 0; k < 3; ++k) {
            c |= (pw[k] < t.lo[k] ? 1u : 0u) << k;
            c |= (pw[k] > t.hi[k] ? 1u : 0u) << (3 + k);
        }
        for (int i = 0; i < 4; ++i) {
            const double sum =
                t.pn[i][0] * pw[0] + t.pn[i][1] * pw[1] + t.pn[i][2] * pw[2] - t.pd[i];
            c |= (sum > t.ptol[i] ? 1u : 0u) << (6 + i);
        }
        return c;
    }
};

#if defined(__SSE2__)
/// The same code in SSE2, two planes (or axes) per register, evaluated in the scalar order,
/// bit for bit.
struct Sse2Coder {
    const TetPlanes& t;
    __m128d lo01, hi01, nx[2], ny[2], nz[2], nd[2], nt[2];
    explicit Sse2Coder(const TetPlanes& planes) : t(planes) {
        lo01 = _mm_setr_pd(t.lo[0], t.lo[1]);
        hi01 = _mm_setr_pd(t.hi[0], t.hi[1]);
        for (int h = 0; h < 2; ++h) {
            nx[h] = _mm_setr_pd(t.pn[2 * h][0], t.pn[2 * h + 1][0]);
            ny[h] = _mm_setr_pd(t.pn[2 * h][1], t.pn[2 * h + 1][1]);
            nz[h] = _mm_setr_pd(t.pn[2 * h][2], t.pn[2 * h + 1][2]);
            nd[h] = _mm_setr_pd(t.pd[2 * h], t.pd[2 * h + 1]);
            nt[h] = _mm_setr_pd(t.ptol[2 * h], t.ptol[2 * h + 1]);
        }
    }
    unsigned operator()(const double* pw) const {
        const __m128d xy = _mm_loadu_pd(pw);
        unsigned c = static_cast<unsigned>(_mm_movemask_pd(_mm_cmplt_pd(xy, lo01))) |
                     (pw[2] < t.lo[2] ? 4u : 0u) |
                     static_cast<unsigned>(_mm_movemask_pd(_mm_cmpgt_pd(xy, hi01))) << 3 |
                     (pw[2] > t.hi[2] ? 32u : 0u);
        const __m128d px = _mm_set1_pd(pw[0]), py = _mm_set1_pd(pw[1]), pz = _mm_set1_pd(pw[2]);
        for (int h = 0; h < 2; ++h) {
            const __m128d sum =
                _mm_sub_pd(_mm_add_pd(_mm_add_pd(_mm_mul_pd(nx[h], px), _mm_mul_pd(ny[h], py)),
                                      _mm_mul_pd(nz[h], pz)),
                           nd[h]);
            c |= static_cast<unsigned>(_mm_movemask_pd(_mm_cmpgt_pd(sum, nt[h]))) << (6 + 2 * h);
        }
        return c;
    }
};
using FastCoder = Sse2Coder;
#else
using FastCoder = PortableCoder;
#endif

/// Whether w lies in the closed tet tv (VTK-negative orient3d(tv) = -1). Exact.
bool in_closed_tet(const FrontView& front, const std::array<std::int32_t, 4>& tv, std::int32_t w) {
    for (int i = 0; i < 4; ++i) {
        const int s = core::orient3d(front.p(tv[kF[i][0]]), front.p(tv[kF[i][1]]),
                                     front.p(tv[kF[i][2]]), front.p(w));
        if (s != 0 && s != kInside[i]) return false;
    }
    return true;
}

}  // namespace

bool improper_intersection(const double* xyz, std::int32_t s0, std::int32_t s1, std::int32_t t0,
                           std::int32_t t1, std::int32_t t2) {
    auto p = [xyz](std::int32_t v) { return xyz + 3 * static_cast<std::size_t>(v); };
    const bool in0 = s0 == t0 || s0 == t1 || s0 == t2;
    const bool in1 = s1 == t0 || s1 == t1 || s1 == t2;
    if (in0 && in1) return false;
    if (!in0 && !in1) {
        for (int a = 0; a < 3; ++a) {  // cheap box rejection
            const double smin = std::min(p(s0)[a], p(s1)[a]);
            const double smax = std::max(p(s0)[a], p(s1)[a]);
            const double tmin = std::min({p(t0)[a], p(t1)[a], p(t2)[a]});
            const double tmax = std::max({p(t0)[a], p(t1)[a], p(t2)[a]});
            if (smax < tmin || smin > tmax) return false;
        }
        return core::segment_intersects_triangle(p(s0), p(s1), p(t0), p(t1), p(t2));
    }
    const std::int32_t v = in0 ? s0 : s1, e = in0 ? s1 : s0;
    // Sharing vertex v, the segment can meet the triangle elsewhere only in its plane.
    if (core::orient3d(p(t0), p(t1), p(t2), p(e)) != 0) return false;
    if (core::segment_intersects_triangle(p(e), p(e), p(t0), p(t1), p(t2))) return true;
    std::int32_t o[2], n = 0;
    for (std::int32_t w : {t0, t1, t2})
        if (w != v) o[n++] = w;
    return core::segment_intersects_triangle(p(v), p(e), p(o[0]), p(o[1]), p(o[1]));
}

bool is_valid_tet_reference(const CandidateTet& tet, const FrontView& front,
                            std::span<const std::int32_t> near) {
    const auto& tv = tet.v;
    const std::int32_t q = tv[3];
    if (core::orient3d(front.p(tv[0]), front.p(tv[1]), front.p(tv[2]), front.p(q)) != -1)
        return false;
    for (const std::int32_t f : near) {
        const auto& t = front.face(f);
        // point in tetrahedron: no other front node in the closed tet
        for (const std::int32_t w : t)
            if (std::find(tv.begin(), tv.end(), w) == tv.end() && in_closed_tet(front, tv, w))
                return false;
        // edge-face intersection (1): no front edge through a new face
        for (int e = 0; e < 3; ++e)
            for (int i = 0; i < 3; ++i)
                if (tet.face_new[i] && improper_intersection(front.xyz, t[e], t[(e + 1) % 3], tv[i],
                                                             tv[(i + 1) % 3], q))
                    return false;
        // over the manifold, edge-face intersection (1) and (2): no new edge through a front face
        for (int i = 0; i < 3; ++i)
            if (tet.edge_new[i] && improper_intersection(front.xyz, tv[i], q, t[0], t[1], t[2]))
                return false;
    }
    return true;
}

std::int32_t TetValidity::next_code_stamp() {
    if (++code_stamp_ == std::numeric_limits<std::int32_t>::max()) {
        for (NodeCode& c : code_) c.stamp = 0;
        code_stamp_ = 1;
    }
    return code_stamp_;
}

std::int32_t TetValidity::next_tested_stamp() {
    if (++tested_stamp_ == std::numeric_limits<std::int32_t>::max()) {
        std::fill(tested_.begin(), tested_.end(), 0);
        tested_stamp_ = 1;
    }
    return tested_stamp_;
}

template <class Coder>
bool TetValidity::check(const CandidateTet& tet, const FrontView& front,
                        std::span<const std::int32_t> near) {
    const auto& tv = tet.v;
    const std::int32_t q = tv[3];
    if (core::orient3d(front.p(tv[0]), front.p(tv[1]), front.p(tv[2]), front.p(q)) != -1)
        return false;
    // Outward face planes of the tet, for a conservative filter in doubles: a triangle whose
    // three nodes lie beyond one plane by far more than the rounding error cannot touch the
    // tet; everything else goes to the exact predicates.
    const TetPlanes planes(front, tv);
    const Coder coder(planes);
    const std::int32_t stamp = next_tested_stamp();
    for (std::int32_t v : tv) tested_[v] = stamp;
    // Per node of `near`, once per call (a node is in several faces): bits 0-5 its outcode
    // against the tet's box (bits 0-2 below lo on x, y, z, bits 3-5 above hi), bits 6-9 the
    // planes i it lies beyond by more than ptol, bits 10-13 the planes through it (the tet's
    // own nodes).
    const std::int32_t cstamp = next_code_stamp();
    for (int j = 0; j < 4; ++j)
        code_[tv[j]] = {cstamp, static_cast<std::uint16_t>(kOnPlanes[j] << 10)};  // in the box
    auto code_of = [&](std::int32_t w) -> std::uint16_t {
        if (code_[w].stamp == cstamp) return code_[w].code;
        const auto c = static_cast<std::uint16_t>(coder(front.p(w)));
        code_[w] = {cstamp, c};
        return c;
    };
    // First the filters, over every face of `near`, without a branch on their outcome (a
    // branch here was mispredicted about once a face): the faces left go to `suspects_`.
    suspects_.resize(near.size());
    std::size_t ns = 0;
    for (std::int32_t f : near) {
        const auto& t = front.face(f);
        const std::uint16_t c0 = code_of(t[0]), c1 = code_of(t[1]), c2 = code_of(t[2]);
        // The triangle's box misses the tet's: all three nodes beyond one side of it.
        const bool misses = (c0 & c1 & c2 & 0x3F) != 0;
        // A node of the triangle that spans plane i lies on it exactly; when the others lie
        // beyond it, the triangle meets the closed tet only in nodes (or the edge) they share,
        // which fails none of the tests below: the triangles around the tet's own nodes, most
        // of `near`, need no exact test. Per plane: every node on it or beyond it, and not all
        // on it.
        const unsigned on0 = c0 >> 10, on1 = c1 >> 10, on2 = c2 >> 10;
        const unsigned ok =
            (on0 | ((c0 >> 6) & 0xF)) & (on1 | ((c1 >> 6) & 0xF)) & (on2 | ((c2 >> 6) & 0xF));
        const bool beyond = (ok & ~(on0 & on1 & on2) & 0xF) != 0;
        // the base and the front faces the tet closes are its own faces
        const bool own =
            (f == tet.own[0]) | (f == tet.own[1]) | (f == tet.own[2]) | (f == tet.own[3]);
        suspects_[ns] = {f, {c0, c1, c2}};
        ns += !(misses | beyond | own);
    }
    for (std::size_t j = 0; j < ns; ++j) {
        const auto& t = front.face(suspects_[j].f);
        const std::uint16_t* const code = suspects_[j].code;
        for (int k = 0; k < 3; ++k) {
            const std::int32_t w = t[k];
            if (tested_[w] == stamp) continue;
            tested_[w] = stamp;
            // outside the tet's box, or beyond one of its planes: outside the tet
            if ((code[k] & 0x3FF) != 0) continue;
            if (in_closed_tet(front, tv, w)) return false;
        }
        for (int e = 0; e < 3; ++e) {
            const std::int32_t e0 = t[e], e1 = t[(e + 1) % 3];
            // Both ends beyond one side of the tet's box: the edge misses the tet. Both on or
            // beyond one of its planes and not both on it: the edge meets the closed tet at
            // most in an end that is a tet node, no improper intersection with any new face.
            // Otherwise both ends beyond the plane of new face i (plane i + 1: (a, b, q),
            // (b, c, q), (c, a, q)): the edge misses that face.
            const unsigned both = code[e] & code[(e + 1) % 3];
            if ((both & 0x3F) != 0) continue;
            const unsigned s0 = code[e] >> 10, s1 = code[(e + 1) % 3] >> 10;
            if (((s0 | ((code[e] >> 6) & 0xF)) & (s1 | ((code[(e + 1) % 3] >> 6) & 0xF)) &
                 ~(s0 & s1) & 0xF) != 0)
                continue;
            for (int i = 0; i < 3; ++i)
                if (tet.face_new[i] && (both & (1u << (7 + i))) == 0 &&
                    improper_intersection(front.xyz, e0, e1, tv[i], tv[(i + 1) % 3], q))
                    return false;
        }
        for (int i = 0; i < 3; ++i)
            if (tet.edge_new[i] && improper_intersection(front.xyz, tv[i], q, t[0], t[1], t[2]))
                return false;
    }
    return true;
}

bool TetValidity::is_valid(const CandidateTet& tet, const FrontView& front,
                           std::span<const std::int32_t> near) {
    return check<FastCoder>(tet, front, near);
}

bool TetValidity::is_valid_portable(const CandidateTet& tet, const FrontView& front,
                                    std::span<const std::int32_t> near) {
    return check<PortableCoder>(tet, front, near);
}

}  // namespace frontmesh::volume

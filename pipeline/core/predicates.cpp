#include "pipeline/core/predicates.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace frontmesh::core {
namespace {

// ---------------------------------------------------------------------------------------------
// Floating-point filter (semi-static). A determinant evaluated in doubles equals the exact
// determinant of the (exactly subtracted) coordinate differences with every monomial m
// multiplied by at most k factors (1 + delta), |delta| <= u = 2^-53, where k counts the
// roundings on m's path (differences, products, sums). Hence |error| <= gamma_k * P with
// P = sum |m|, and the computed permanent P' >= P (1 - gamma_k). The sign is certain when
// |det| > (k + 1) u P', which absorbs gamma_k / (1 - gamma_k) and the rounding of (k + 1) u P'.
// Underflow breaks relative error bounds, so tiny permanents go to the exact path; overflow
// yields inf/NaN, which fails the comparison and also goes to the exact path.
// ---------------------------------------------------------------------------------------------
constexpr double unit_roundoff = std::numeric_limits<double>::epsilon() / 2.0;
constexpr double orient2d_bound = 5.0 * unit_roundoff;   // k = 4: 2 differences, product, sum
constexpr double orient3d_bound = 9.0 * unit_roundoff;   // k = 8
constexpr double insphere_bound = 17.0 * unit_roundoff;  // k = 16
constexpr double min_permanent = 0x1p-960;

int sign_of(double x) { return (x > 0.0) - (x < 0.0); }

// ---------------------------------------------------------------------------------------------
// Expansion arithmetic (Shewchuk, DCG 18(3) 1997, §2). An expansion is a sum of doubles stored
// in increasing order of magnitude, non-overlapping, without zero components, so that its sign
// is the sign of its last component. Requires round-to-nearest-even binary64 (SSE2 on x86-64).
// Exact as long as no product underflows or overflows; callers scale the input to [1, 2).
// ---------------------------------------------------------------------------------------------

// s + t == a + b exactly, s = fl(a + b) (Knuth's two-sum, §2.5 Thm. 7).
inline void two_sum(double a, double b, double& s, double& t) {
    s = a + b;
    const double b_part = s - a;
    const double a_part = s - b_part;
    t = (a - a_part) + (b - b_part);
}

// p + t == a * b exactly, p = fl(a * b); the fused multiply-add yields the rounding error.
inline void two_product(double a, double b, double& p, double& t) {
    p = a * b;
    t = std::fma(a, b, -p);
}

// h = e + f (§2.6 Thm. 13, merge by magnitude then a chain of two-sums), zero components
// dropped. h holds ne + nf entries and aliases neither input. Returns the length of h.
int sum_into(const double* e, int ne, const double* f, int nf, double* h) {
    if (ne + nf == 0) return 0;
    int i = 0, j = 0, k = 0;
    auto next = [&]() {
        if (j >= nf || (i < ne && std::abs(e[i]) <= std::abs(f[j]))) return e[i++];
        return f[j++];
    };
    double q = next();
    while (i < ne || j < nf) {
        const double g = next();
        double s, t;
        two_sum(q, g, s, t);
        if (t != 0.0) h[k++] = t;
        q = s;
    }
    if (q != 0.0) h[k++] = q;
    return k;
}

// h = b * e (§2.7 Thm. 19), zero components dropped. h holds 2 ne entries. Returns its length.
int scale_into(const double* e, int ne, double b, double* h) {
    if (ne == 0 || b == 0.0) return 0;
    int k = 0;
    double q, t;
    two_product(e[0], b, q, t);
    if (t != 0.0) h[k++] = t;
    for (int i = 1; i < ne; ++i) {
        double p_hi, p_lo, s, u;
        two_product(e[i], b, p_hi, p_lo);
        two_sum(q, p_lo, s, u);
        if (u != 0.0) h[k++] = u;
        two_sum(p_hi, s, q, u);
        if (u != 0.0) h[k++] = u;
    }
    if (q != 0.0) h[k++] = q;
    return k;
}

// An expansion with room for N components; c[n..N) is unused.
template <int N>
struct Expansion {
    double c[N] = {};
    int n = 0;

    int sign() const { return n == 0 ? 0 : sign_of(c[n - 1]); }
};

Expansion<2> product(double a, double b) {
    Expansion<2> r;
    double p, t;
    two_product(a, b, p, t);
    if (t != 0.0) r.c[r.n++] = t;
    if (p != 0.0) r.c[r.n++] = p;
    return r;
}

template <int A, int B>
Expansion<A + B> operator+(const Expansion<A>& x, const Expansion<B>& y) {
    Expansion<A + B> r;
    r.n = sum_into(x.c, x.n, y.c, y.n, r.c);
    return r;
}

template <int A>
Expansion<A> operator-(Expansion<A> x) {
    for (int i = 0; i < x.n; ++i) x.c[i] = -x.c[i];
    return x;
}

template <int A, int B>
Expansion<A + B> operator-(const Expansion<A>& x, const Expansion<B>& y) {
    return x + (-y);
}

// Product of two expansions: the sum over the components of y of x scaled by each.
template <int A, int B>
Expansion<2 * A * B> operator*(const Expansion<A>& x, const Expansion<B>& y) {
    Expansion<2 * A * B> r;
    double buffer[2 * A * B];
    double part[2 * A];
    double* acc = r.c;
    double* other = buffer;
    int n = 0;
    for (int j = 0; j < y.n; ++j) {
        const int np = scale_into(x.c, x.n, y.c[j], part);
        n = sum_into(acc, n, part, np, other);
        std::swap(acc, other);
    }
    if (acc != r.c) std::copy(acc, acc + n, r.c);
    r.n = n;
    return r;
}

template <int A>
Expansion<2 * A> operator*(const Expansion<A>& x, double b) {
    Expansion<2 * A> r;
    r.n = scale_into(x.c, x.n, b, r.c);
    return r;
}

// A heap-backed expansion for the rare, large insphere evaluation.
struct LargeExpansion {
    std::vector<double> c;

    void add_product(const double* x, int nx, const double* y, int ny) {
        std::vector<double> part(2 * static_cast<std::size_t>(nx));
        std::vector<double> out;
        for (int j = 0; j < ny; ++j) {
            const int np = scale_into(x, nx, y[j], part.data());
            out.resize(c.size() + static_cast<std::size_t>(np));
            out.resize(static_cast<std::size_t>(
                sum_into(c.data(), static_cast<int>(c.size()), part.data(), np, out.data())));
            c.swap(out);
        }
    }
    int sign() const { return c.empty() ? 0 : sign_of(c.back()); }
};

// ---------------------------------------------------------------------------------------------
// Exact evaluation. The points are first scaled by one power of two so that the largest
// magnitude lies in [1, 2): exact, keeps every product finite, and leaves the sign unchanged
// because the determinants are homogeneous. If the coordinate differences are exact (common
// for nearby points), the determinant of the differences is expanded; otherwise the equivalent
// determinant with a column of ones on the raw coordinates is (no differences needed).
// ---------------------------------------------------------------------------------------------

// Copies `count` points of `dim` selected coordinates, scaled; false when all are zero.
bool scaled_copy(const double* const* points, int count, const int* coords, int dim,
                 double (*out)[3]) {
    double largest = 0.0;
    for (int p = 0; p < count; ++p)
        for (int k = 0; k < dim; ++k) largest = std::max(largest, std::abs(points[p][coords[k]]));
    if (largest == 0.0) return false;
    const int shift = -std::ilogb(largest);
    if (shift >= -1000 && shift <= 1000) {
        // Multiplying by an exact power of two is cheaper than ldexp per coordinate.
        const double factor = std::bit_cast<double>(static_cast<std::uint64_t>(1023 + shift) << 52);
        for (int p = 0; p < count; ++p)
            for (int k = 0; k < dim; ++k) out[p][k] = points[p][coords[k]] * factor;
    } else {
        for (int p = 0; p < count; ++p)
            for (int k = 0; k < dim; ++k) out[p][k] = std::ldexp(points[p][coords[k]], shift);
    }
    return true;
}

// Exact differences r - s per coordinate; false when one of them is not a double.
bool exact_differences(const double* r, const double* s, int dim, double* out) {
    bool exact = true;
    for (int k = 0; k < dim; ++k) {
        double t;
        two_sum(r[k], -s[k], out[k], t);
        exact = exact && t == 0.0;
    }
    return exact;
}

// a x b - c x d for doubles: 4 components.
Expansion<4> cross_term(double a, double b, double c, double d) {
    return product(a, b) - product(c, d);
}

// p . (q x s) for three 3-vectors of doubles: 24 components.
Expansion<24> det3(const double* p, const double* q, const double* s) {
    return (cross_term(q[1], s[2], q[2], s[1]) * p[0] + cross_term(q[2], s[0], q[0], s[2]) * p[1]) +
           cross_term(q[0], s[1], q[1], s[0]) * p[2];
}

// det[[a, 1], [b, 1], [c, 1], [d, 1]] = det[a - d; b - d; c - d] on raw coordinates.
Expansion<96> det4_ones(const double* a, const double* b, const double* c, const double* d) {
    return (det3(a, b, c) - det3(b, c, d)) + (det3(a, c, d) - det3(a, b, d));
}

// |p|^2 of a 3-vector: 6 components.
Expansion<6> lift(const double* p) {
    return (product(p[0], p[0]) + product(p[1], p[1])) + product(p[2], p[2]);
}

int orient2d_exact(const double* a, const double* b, const double* c, int i, int j) {
    const double* points[3] = {a, b, c};
    const int coords[2] = {i, j};
    double p[3][3];
    if (!scaled_copy(points, 3, coords, 2, p)) return 0;
    double ac[2], bc[2];
    if (exact_differences(p[0], p[2], 2, ac) && exact_differences(p[1], p[2], 2, bc))
        return cross_term(ac[0], bc[1], ac[1], bc[0]).sign();
    // det[[a, 1], [b, 1], [c, 1]] = a x b + b x c + c x a.
    return ((cross_term(p[0][0], p[1][1], p[0][1], p[1][0]) +
             cross_term(p[1][0], p[2][1], p[1][1], p[2][0])) +
            cross_term(p[2][0], p[0][1], p[2][1], p[0][0]))
        .sign();
}

int orient3d_exact(const double* a, const double* b, const double* c, const double* d) {
    const double* points[4] = {a, b, c, d};
    const int coords[3] = {0, 1, 2};
    double p[4][3];
    if (!scaled_copy(points, 4, coords, 3, p)) return 0;
    double ad[3], bd[3], cd[3];
    if (exact_differences(p[0], p[3], 3, ad) && exact_differences(p[1], p[3], 3, bd) &&
        exact_differences(p[2], p[3], 3, cd))
        return det3(ad, bd, cd).sign();
    return det4_ones(p[0], p[1], p[2], p[3]).sign();
}

int insphere_exact(const double* a, const double* b, const double* c, const double* d,
                   const double* e) {
    const double* points[5] = {a, b, c, d, e};
    const int coords[3] = {0, 1, 2};
    double p[5][3];
    if (!scaled_copy(points, 5, coords, 3, p)) return 0;
    double v[4][3];
    bool exact = true;
    for (int r = 0; r < 4; ++r) exact = exact_differences(p[r], p[4], 3, v[r]) && exact;
    if (exact) {
        // det[p_r - e, |p_r - e|^2] (rows a..d), expanded along the lift column.
        return ((lift(v[1]) * det3(v[0], v[2], v[3]) - lift(v[0]) * det3(v[1], v[2], v[3])) +
                (lift(v[3]) * det3(v[0], v[1], v[2]) - lift(v[2]) * det3(v[0], v[1], v[3])))
            .sign();
    }
    // det[[p, |p|^2, 1]] over a..e, expanded along the lift column: sum over rows r of
    // (-1)^(r+1) |p_r|^2 det4_ones(the other four points in order).
    LargeExpansion total;
    for (int r = 0; r < 5; ++r) {
        const double* q[4];
        for (int s = 0, k = 0; s < 5; ++s)
            if (s != r) q[k++] = p[s];
        Expansion<96> minor = det4_ones(q[0], q[1], q[2], q[3]);
        if (r % 2 == 0) minor = -minor;
        const Expansion<6> l = lift(p[r]);
        total.add_product(minor.c, minor.n, l.c, l.n);
    }
    return total.sign();
}

// The filter stage of orient3d: the certain sign, or unknown_sign.
constexpr int unknown_sign = 2;

int orient3d_filter(const double* a, const double* b, const double* c, const double* d) {
    const double adx = a[0] - d[0], ady = a[1] - d[1], adz = a[2] - d[2];
    const double bdx = b[0] - d[0], bdy = b[1] - d[1], bdz = b[2] - d[2];
    const double cdx = c[0] - d[0], cdy = c[1] - d[1], cdz = c[2] - d[2];
    const double bc_x = bdy * cdz, cb_x = bdz * cdy;
    const double bc_y = bdz * cdx, cb_y = bdx * cdz;
    const double bc_z = bdx * cdy, cb_z = bdy * cdx;
    const double det = (adx * (bc_x - cb_x) + ady * (bc_y - cb_y)) + adz * (bc_z - cb_z);
    const double permanent = (std::abs(adx) * (std::abs(bc_x) + std::abs(cb_x)) +
                              std::abs(ady) * (std::abs(bc_y) + std::abs(cb_y))) +
                             std::abs(adz) * (std::abs(bc_z) + std::abs(cb_z));
    if (permanent >= min_permanent && std::abs(det) > orient3d_bound * permanent)
        return sign_of(det);
    return unknown_sign;
}

// ---------------------------------------------------------------------------------------------
// Intersection tests built from the sign predicates and exact coordinate comparisons.
// ---------------------------------------------------------------------------------------------

constexpr int projections[3][2] = {{0, 1}, {1, 2}, {2, 0}};

bool same_point(const double* p, const double* q) {
    return p[0] == q[0] && p[1] == q[1] && p[2] == q[2];
}

// x within the bounding box of p and q on coordinates i, j (i == j tests one coordinate).
bool in_box(const double* x, const double* p, const double* q, int i, int j) {
    for (int k : {i, j})
        if (x[k] < std::min(p[k], q[k]) || x[k] > std::max(p[k], q[k])) return false;
    return true;
}

bool point_on_segment(const double* x, const double* p, const double* q) {
    return in_box(x, p, q, 0, 1) && in_box(x, p, q, 2, 2) && is_degenerate_triangle(p, q, x);
}

// The two points of a collinear (possibly coincident) triple that span it.
void collinear_extremes(const double* a, const double* b, const double* c, const double*& lo,
                        const double*& hi) {
    lo = hi = a;
    for (int k = 0; k < 3; ++k) {
        if (a[k] == b[k] && a[k] == c[k]) continue;
        // The line is not perpendicular to axis k, so order along k is order along the line.
        for (const double* p : {b, c}) {
            if (p[k] < lo[k]) lo = p;
            if (p[k] > hi[k]) hi = p;
        }
        return;
    }
}

// Closed segments in the projection on (i, j); either may be a single point.
bool segments_intersect_2d(const double* p, const double* q, const double* r, const double* s,
                           int i, int j) {
    const int o1 = orient2d(p, q, r, i, j), o2 = orient2d(p, q, s, i, j);
    if (o1 * o2 > 0) return false;
    const int o3 = orient2d(r, s, p, i, j), o4 = orient2d(r, s, q, i, j);
    if (o3 * o4 > 0) return false;
    if (o1 * o2 < 0 && o3 * o4 < 0) return true;
    return (o1 == 0 && in_box(r, p, q, i, j)) || (o2 == 0 && in_box(s, p, q, i, j)) ||
           (o3 == 0 && in_box(p, r, s, i, j)) || (o4 == 0 && in_box(q, r, s, i, j));
}

// x in the closed triangle (a, b, c), which is not degenerate in the projection on (i, j).
bool point_in_triangle_2d(const double* x, const double* a, const double* b, const double* c, int i,
                          int j) {
    const int o1 = orient2d(a, b, x, i, j), o2 = orient2d(b, c, x, i, j);
    if (o1 * o2 < 0) return false;
    const int o3 = orient2d(c, a, x, i, j);
    return o1 * o3 >= 0 && o2 * o3 >= 0;
}

// Closed segment against the closed triangle (a, b, c), not degenerate in the projection.
bool segment_triangle_2d(const double* p, const double* q, const double* a, const double* b,
                         const double* c, int i, int j) {
    return point_in_triangle_2d(p, a, b, c, i, j) || point_in_triangle_2d(q, a, b, c, i, j) ||
           segments_intersect_2d(p, q, a, b, i, j) || segments_intersect_2d(p, q, b, c, i, j) ||
           segments_intersect_2d(p, q, c, a, i, j);
}

// Closed segments in 3-D, either possibly a single point.
bool segments_intersect_3d(const double* p, const double* q, const double* r, const double* s) {
    if (same_point(p, q)) return point_on_segment(p, r, s);
    if (same_point(r, s)) return point_on_segment(r, p, q);
    if (orient3d(p, q, r, s) != 0) return false;
    // Coplanar: a projection that keeps p, q, r (or p, q, s) non-collinear is injective on
    // their common plane.
    for (const auto& ij : projections) {
        if (orient2d(p, q, r, ij[0], ij[1]) != 0 || orient2d(p, q, s, ij[0], ij[1]) != 0)
            return segments_intersect_2d(p, q, r, s, ij[0], ij[1]);
    }
    // All four on the line through p != q: compare along an axis the line is not
    // perpendicular to.
    const int k = p[0] != q[0] ? 0 : p[1] != q[1] ? 1 : 2;
    return std::max(std::min(p[k], q[k]), std::min(r[k], s[k])) <=
           std::min(std::max(p[k], q[k]), std::max(r[k], s[k]));
}

// Segment [p, q] against triangle (a, b, c), given op = orient3d(a, b, c, p) and
// oq = orient3d(a, b, c, q), either of which may still be unknown_sign (filter undecided); an
// exact evaluation, when needed, is stored back so that callers can reuse it.
bool segment_triangle(const double* p, const double* q, int& op, int& oq, const double* a,
                      const double* b, const double* c) {
    if (op != unknown_sign && oq != unknown_sign && op * oq > 0) return false;
    if (op == unknown_sign || oq == unknown_sign) {
        // Before an exact evaluation, try to reject cheaply: if the line pq passes two edges
        // of the triangle on opposite sides, it is not coplanar with the triangle and misses
        // it (for a degenerate triangle, a line meeting it gives all zeros), so the segment
        // misses it too.
        const int s1 = orient3d_filter(p, q, a, b);
        const int s2 = orient3d_filter(p, q, b, c);
        const int s3 = orient3d_filter(p, q, c, a);
        const bool positive = s1 == 1 || s2 == 1 || s3 == 1;
        const bool negative = s1 == -1 || s2 == -1 || s3 == -1;
        if (positive && negative) return false;
        if (op == unknown_sign) op = orient3d_exact(a, b, c, p);
        if (oq == unknown_sign) oq = orient3d_exact(a, b, c, q);
        if (op * oq > 0) return false;
    }
    if (op == 0 && oq == 0) {
        // In the plane of the triangle, or the triangle is degenerate.
        for (const auto& ij : projections) {
            if (orient2d(a, b, c, ij[0], ij[1]) != 0)
                return segment_triangle_2d(p, q, a, b, c, ij[0], ij[1]);
        }
        const double *lo, *hi;
        collinear_extremes(a, b, c, lo, hi);
        return segments_intersect_3d(p, q, lo, hi);
    }
    // The segment meets the plane (of a non-degenerate triangle) in one point, which lies in
    // the closed triangle iff the line pq passes no two edges on opposite sides.
    const int s1 = orient3d(p, q, a, b);
    const int s2 = orient3d(p, q, b, c);
    if (s1 * s2 < 0) return false;
    const int s3 = orient3d(p, q, c, a);
    return s1 * s3 >= 0 && s2 * s3 >= 0;
}

// True when three known signs are all +1 or all -1 (unknown_sign counts as neither).
bool all_strictly_same_side(const int s[3]) {
    return (s[0] == 1 && s[1] == 1 && s[2] == 1) || (s[0] == -1 && s[1] == -1 && s[2] == -1);
}

}  // namespace

int orient2d(const double* a, const double* b, const double* c, int i, int j) {
    const double acx = a[i] - c[i], acy = a[j] - c[j];
    const double bcx = b[i] - c[i], bcy = b[j] - c[j];
    const double left = acx * bcy, right = acy * bcx;
    const double det = left - right;
    const double permanent = std::abs(left) + std::abs(right);
    if (permanent >= min_permanent && std::abs(det) > orient2d_bound * permanent)
        return sign_of(det);
    return orient2d_exact(a, b, c, i, j);
}

int orient3d(const double* a, const double* b, const double* c, const double* d) {
    const int sign = orient3d_filter(a, b, c, d);
    return sign != unknown_sign ? sign : orient3d_exact(a, b, c, d);
}

int insphere(const double* a, const double* b, const double* c, const double* d, const double* e) {
    double v[4][3];
    for (int k = 0; k < 3; ++k) {
        v[0][k] = a[k] - e[k];
        v[1][k] = b[k] - e[k];
        v[2][k] = c[k] - e[k];
        v[3][k] = d[k] - e[k];
    }
    // det3 of three difference rows, and the same with absolute values (the permanent).
    auto det3_and_permanent = [&](int r, int s, int t, double& permanent) {
        const double* p = v[r];
        const double* q = v[s];
        const double* w = v[t];
        const double x1 = q[1] * w[2], x2 = q[2] * w[1];
        const double y1 = q[2] * w[0], y2 = q[0] * w[2];
        const double z1 = q[0] * w[1], z2 = q[1] * w[0];
        permanent = (std::abs(p[0]) * (std::abs(x1) + std::abs(x2)) +
                     std::abs(p[1]) * (std::abs(y1) + std::abs(y2))) +
                    std::abs(p[2]) * (std::abs(z1) + std::abs(z2));
        return (p[0] * (x1 - x2) + p[1] * (y1 - y2)) + p[2] * (z1 - z2);
    };
    double lifts[4];
    for (int r = 0; r < 4; ++r)
        lifts[r] = (v[r][0] * v[r][0] + v[r][1] * v[r][1]) + v[r][2] * v[r][2];
    double p0, p1, p2, p3;
    const double m0 = det3_and_permanent(1, 2, 3, p0);
    const double m1 = det3_and_permanent(0, 2, 3, p1);
    const double m2 = det3_and_permanent(0, 1, 3, p2);
    const double m3 = det3_and_permanent(0, 1, 2, p3);
    // det[p - e, |p - e|^2] over rows a..d, expanded along the lift column.
    const double det = (lifts[1] * m1 - lifts[0] * m0) + (lifts[3] * m3 - lifts[2] * m2);
    const double permanent = (lifts[1] * p1 + lifts[0] * p0) + (lifts[3] * p3 + lifts[2] * p2);
    if (permanent >= min_permanent && std::abs(det) > insphere_bound * permanent)
        return sign_of(det);
    return insphere_exact(a, b, c, d, e);
}

bool is_degenerate_triangle(const double* a, const double* b, const double* c) {
    return orient2d(a, b, c, 0, 1) == 0 && orient2d(a, b, c, 1, 2) == 0 &&
           orient2d(a, b, c, 2, 0) == 0;
}

bool segment_intersects_triangle(const double* p, const double* q, const double* a, const double* b,
                                 const double* c) {
    int op = orient3d_filter(a, b, c, p), oq = orient3d_filter(a, b, c, q);
    return segment_triangle(p, q, op, oq, a, b, c);
}

bool triangles_intersect(const double* a0, const double* a1, const double* a2, const double* b0,
                         const double* b1, const double* b2) {
    const double* a[3] = {a0, a1, a2};
    const double* b[3] = {b0, b1, b2};
    int sb[3], sa[3];  // sides of b's vertices w.r.t. a's plane, and the reverse
    for (int k = 0; k < 3; ++k) sb[k] = orient3d_filter(a0, a1, a2, b[k]);
    if (all_strictly_same_side(sb)) return false;
    for (int k = 0; k < 3; ++k) sa[k] = orient3d_filter(b0, b1, b2, a[k]);
    if (all_strictly_same_side(sa)) return false;
    // Coplanarity needs six exact zeros, possible only when the filter decided none of them;
    // otherwise the undecided signs are resolved lazily by segment_triangle.
    if (std::all_of(sb, sb + 3, [](int x) { return x == unknown_sign; }) &&
        std::all_of(sa, sa + 3, [](int x) { return x == unknown_sign; })) {
        for (int k = 0; k < 3; ++k) {
            sb[k] = orient3d_exact(a0, a1, a2, b[k]);
            sa[k] = orient3d_exact(b0, b1, b2, a[k]);
        }
        if (all_strictly_same_side(sb) || all_strictly_same_side(sa)) return false;
    }
    const bool b_in_plane_a = sb[0] == 0 && sb[1] == 0 && sb[2] == 0;
    const bool a_in_plane_b = sa[0] == 0 && sa[1] == 0 && sa[2] == 0;
    if (b_in_plane_a && a_in_plane_b) {
        // Coplanar: when both are proper triangles, one projection injective on the plane.
        for (const auto& ij : projections) {
            const int i = ij[0], j = ij[1];
            if (orient2d(a0, a1, a2, i, j) == 0 || orient2d(b0, b1, b2, i, j) == 0) continue;
            for (int k = 0; k < 3; ++k)
                if (point_in_triangle_2d(a[k], b0, b1, b2, i, j) ||
                    point_in_triangle_2d(b[k], a0, a1, a2, i, j))
                    return true;
            for (int k = 0; k < 3; ++k)
                for (int l = 0; l < 3; ++l)
                    if (segments_intersect_2d(a[k], a[(k + 1) % 3], b[l], b[(l + 1) % 3], i, j))
                        return true;
            return false;
        }
    }
    // The closed triangles meet iff a point of the relative boundary of their intersection
    // exists, and such a point lies on an edge of one of them inside the other.
    for (int k = 0; k < 3; ++k) {
        const int l = (k + 1) % 3;
        if (segment_triangle(a[k], a[l], sa[k], sa[l], b0, b1, b2)) return true;
        if (segment_triangle(b[k], b[l], sb[k], sb[l], a0, a1, a2)) return true;
    }
    return false;
}

}  // namespace frontmesh::core

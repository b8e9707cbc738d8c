#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include <catch2/catch.hpp>

#include "pipeline/core/predicates.h"
#include "pipeline/core/quality.h"

using namespace frontmesh::core;

namespace {

using P3 = std::array<double, 3>;

// ---------------------------------------------------------------------------------------------
// Independent exact reference: arbitrary-precision integers (sign + magnitude, base 2^32).
// Doubles are converted exactly after multiplying all of them by one power of two; the
// determinants below are homogeneous, so their signs are unchanged.
// ---------------------------------------------------------------------------------------------
class BigInt {
public:
    BigInt() = default;
    explicit BigInt(std::int64_t v) {
        negative_ = v < 0;
        std::uint64_t m =
            negative_ ? 0 - static_cast<std::uint64_t>(v) : static_cast<std::uint64_t>(v);
        for (; m != 0; m >>= 32) digits_.push_back(static_cast<std::uint32_t>(m));
    }
    static BigInt power_of_two(int k) {
        BigInt r;
        r.digits_.assign(static_cast<std::size_t>(k / 32) + 1, 0u);
        r.digits_.back() = 1u << (k % 32);
        return r;
    }
    int sign() const { return digits_.empty() ? 0 : (negative_ ? -1 : 1); }
    BigInt operator-() const {
        BigInt r = *this;
        if (!r.digits_.empty()) r.negative_ = !r.negative_;
        return r;
    }
    friend BigInt operator+(const BigInt& a, const BigInt& b) {
        BigInt r;
        if (a.negative_ == b.negative_) {
            r.digits_ = add(a.digits_, b.digits_);
            r.negative_ = a.negative_;
        } else {
            const int c = compare(a.digits_, b.digits_);
            if (c == 0) return r;
            const BigInt& big = c > 0 ? a : b;
            const BigInt& small = c > 0 ? b : a;
            r.digits_ = subtract(big.digits_, small.digits_);
            r.negative_ = big.negative_;
        }
        r.trim();
        return r;
    }
    friend BigInt operator-(const BigInt& a, const BigInt& b) { return a + (-b); }
    friend BigInt operator*(const BigInt& a, const BigInt& b) {
        BigInt r;
        if (a.digits_.empty() || b.digits_.empty()) return r;
        r.digits_.assign(a.digits_.size() + b.digits_.size(), 0u);
        for (std::size_t i = 0; i < a.digits_.size(); ++i) {
            std::uint64_t carry = 0;
            for (std::size_t j = 0; j < b.digits_.size(); ++j) {
                const std::uint64_t cur =
                    r.digits_[i + j] + std::uint64_t(a.digits_[i]) * b.digits_[j] + carry;
                r.digits_[i + j] = static_cast<std::uint32_t>(cur);
                carry = cur >> 32;
            }
            r.digits_[i + b.digits_.size()] = static_cast<std::uint32_t>(carry);
        }
        r.negative_ = a.negative_ != b.negative_;
        r.trim();
        return r;
    }

private:
    using Digits = std::vector<std::uint32_t>;
    static int compare(const Digits& a, const Digits& b) {
        if (a.size() != b.size()) return a.size() < b.size() ? -1 : 1;
        for (std::size_t i = a.size(); i-- > 0;)
            if (a[i] != b[i]) return a[i] < b[i] ? -1 : 1;
        return 0;
    }
    static Digits add(const Digits& a, const Digits& b) {
        Digits r(std::max(a.size(), b.size()) + 1, 0u);
        std::uint64_t carry = 0;
        for (std::size_t i = 0; i < r.size(); ++i) {
            const std::uint64_t cur =
                carry + (i < a.size() ? a[i] : 0u) + (i < b.size() ? b[i] : 0u);
            r[i] = static_cast<std::uint32_t>(cur);
            carry = cur >> 32;
        }
        return r;
    }
    static Digits subtract(const Digits& a, const Digits& b) {  // |a| >= |b|
        Digits r(a.size(), 0u);
        std::int64_t borrow = 0;
        for (std::size_t i = 0; i < a.size(); ++i) {
            std::int64_t cur =
                std::int64_t(a[i]) - (i < b.size() ? std::int64_t(b[i]) : 0) - borrow;
            borrow = cur < 0 ? 1 : 0;
            if (cur < 0) cur += std::int64_t(1) << 32;
            r[i] = static_cast<std::uint32_t>(cur);
        }
        return r;
    }
    void trim() {
        while (!digits_.empty() && digits_.back() == 0) digits_.pop_back();
        if (digits_.empty()) negative_ = false;
    }

    bool negative_ = false;
    Digits digits_;
};

// Exact integer images of `values` scaled by a common power of two.
std::vector<BigInt> exact_integers(const std::vector<double>& values) {
    int shift = 0;
    for (double x : values) {
        if (x == 0.0) continue;
        int e;
        std::frexp(x, &e);
        shift = std::max(shift, 53 - e);
    }
    std::vector<BigInt> out;
    for (double x : values) {
        int e;
        const double mantissa = std::frexp(x, &e);
        const auto m = static_cast<std::int64_t>(std::ldexp(mantissa, 53));
        out.push_back(x == 0.0 ? BigInt() : BigInt(m) * BigInt::power_of_two(e - 53 + shift));
    }
    return out;
}

using Matrix = std::vector<std::vector<BigInt>>;

BigInt determinant(const Matrix& m) {
    const std::size_t n = m.size();
    if (n == 1) return m[0][0];
    BigInt total;
    for (std::size_t col = 0; col < n; ++col) {
        if (m[0][col].sign() == 0) continue;
        Matrix minor;
        for (std::size_t r = 1; r < n; ++r) {
            std::vector<BigInt> row;
            for (std::size_t c = 0; c < n; ++c)
                if (c != col) row.push_back(m[r][c]);
            minor.push_back(row);
        }
        const BigInt term = m[0][col] * determinant(minor);
        total = col % 2 == 0 ? total + term : total - term;
    }
    return total;
}

// det[[p, 1]] over a, b, c, d = det[a - d; b - d; c - d].
int reference_orient3d(const P3& a, const P3& b, const P3& c, const P3& d) {
    const auto x =
        exact_integers({a[0], a[1], a[2], b[0], b[1], b[2], c[0], c[1], c[2], d[0], d[1], d[2]});
    Matrix m;
    for (int r = 0; r < 4; ++r) m.push_back({x[3 * r], x[3 * r + 1], x[3 * r + 2], BigInt(1)});
    return determinant(m).sign();
}

int reference_orient2d(const P3& a, const P3& b, const P3& c, int i, int j) {
    const auto x = exact_integers({a[i], a[j], b[i], b[j], c[i], c[j]});
    Matrix m;
    for (int r = 0; r < 3; ++r) m.push_back({x[2 * r], x[2 * r + 1], BigInt(1)});
    return determinant(m).sign();
}

// det[[p, |p|^2, 1]] over a..e: positive inside when orient3d(a, b, c, d) > 0.
int reference_insphere(const P3& a, const P3& b, const P3& c, const P3& d, const P3& e) {
    std::vector<double> values;
    for (const P3* p : {&a, &b, &c, &d, &e}) values.insert(values.end(), p->begin(), p->end());
    const auto x = exact_integers(values);
    Matrix m;
    for (int r = 0; r < 5; ++r) {
        const BigInt& px = x[3 * r];
        const BigInt& py = x[3 * r + 1];
        const BigInt& pz = x[3 * r + 2];
        m.push_back({px, py, pz, px * px + py * py + pz * pz, BigInt(1)});
    }
    return determinant(m).sign();
}

int o3(const P3& a, const P3& b, const P3& c, const P3& d) {
    return orient3d(a.data(), b.data(), c.data(), d.data());
}
int o2(const P3& a, const P3& b, const P3& c, int i = 0, int j = 1) {
    return orient2d(a.data(), b.data(), c.data(), i, j);
}
int is(const P3& a, const P3& b, const P3& c, const P3& d, const P3& e) {
    return insphere(a.data(), b.data(), c.data(), d.data(), e.data());
}

P3 scaled(const P3& p, int k) {
    return {std::ldexp(p[0], k), std::ldexp(p[1], k), std::ldexp(p[2], k)};
}
P3 shifted(const P3& p, double t) { return {p[0] + t, p[1] + t, p[2] + t}; }

// Integer lattice points of the plane 3x + 5y - 7z = 11: (2, 1, 0) + s (7, 0, 3) + t (0, 7, 5).
P3 plane_point(std::int64_t s, std::int64_t t) {
    return {double(2 + 7 * s), double(1 + 7 * t), double(3 * s + 5 * t)};
}

// Double naive determinant, to show that a test input defeats plain floating point.
double naive_orient3d(const P3& a, const P3& b, const P3& c, const P3& d) {
    const double m[3][3] = {{a[0] - d[0], a[1] - d[1], a[2] - d[2]},
                            {b[0] - d[0], b[1] - d[1], b[2] - d[2]},
                            {c[0] - d[0], c[1] - d[1], c[2] - d[2]}};
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) +
           m[0][1] * (m[1][2] * m[2][0] - m[1][0] * m[2][2]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

}  // namespace

TEST_CASE("reference big integers compute correct small determinants", "[core]") {
    CHECK(reference_orient3d({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, -1}) == 1);
    CHECK(reference_orient3d({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}) == -1);
    CHECK(reference_orient2d({0, 0, 0}, {1, 0, 0}, {0, 1, 0}, 0, 1) == 1);
    CHECK((BigInt(-7) * BigInt(6) + BigInt(42)).sign() == 0);
    CHECK((BigInt(INT64_MIN) * BigInt(INT64_MIN) - BigInt::power_of_two(126)).sign() == 0);
    CHECK((BigInt(3) - BigInt::power_of_two(100)).sign() == -1);
}

TEST_CASE("orient3d follows the documented sign convention", "[core]") {
    const P3 a{0, 0, 0}, b{1, 0, 0}, c{0, 1, 0};
    CHECK(o3(a, b, c, {0.2, 0.3, -1}) == 1);  // below the counter-clockwise triangle
    CHECK(o3(a, b, c, {0.2, 0.3, 1}) == -1);
    CHECK(o3(a, b, c, {5, -7, 0}) == 0);
    CHECK(o3(b, a, c, {0.2, 0.3, -1}) == -1);  // swapping two points flips the sign
    // Opposite of the signed tet volume, which is positive when d is on the normal's side.
    const Eigen::Vector3d ea(0, 0, 0), eb(1, 0, 0), ec(0, 1, 0), ed(0.1, 0.2, 0.7);
    CHECK(orient3d(ea, eb, ec, ed) == -1);
    CHECK(tet_signed_volume(ea, eb, ec, ed) > 0.0);
}

TEST_CASE("orient3d is exactly zero on coplanar points at any scale", "[core]") {
    std::mt19937_64 rng(11);
    std::uniform_int_distribution<std::int64_t> coef(-1000, 1000);
    for (int trial = 0; trial < 200; ++trial) {
        P3 p[4];
        for (auto& q : p) q = plane_point(coef(rng), coef(rng));
        for (int k : {-600, -300, -60, 0, 40, 300, 600}) {
            INFO("trial " << trial << " scale 2^" << k);
            CHECK(o3(scaled(p[0], k), scaled(p[1], k), scaled(p[2], k), scaled(p[3], k)) == 0);
            CHECK(o3(scaled(p[3], k), scaled(p[1], k), scaled(p[0], k), scaled(p[2], k)) == 0);
        }
        const double t = std::ldexp(1.0, 40);  // an integer translation keeps them exact
        CHECK(o3(shifted(p[0], t), shifted(p[1], t), shifted(p[2], t), shifted(p[3], t)) == 0);
    }
}

TEST_CASE("orient3d gets the sign of a one-ulp move off the plane", "[core]") {
    std::mt19937_64 rng(12);
    std::uniform_int_distribution<std::int64_t> coef(-1000, 1000);
    int tested = 0;
    for (int trial = 0; trial < 200; ++trial) {
        const std::int64_t s[4] = {coef(rng), coef(rng), coef(rng), coef(rng)};
        const std::int64_t t[4] = {coef(rng), coef(rng), coef(rng), coef(rng)};
        P3 p[4];
        for (int i = 0; i < 4; ++i) p[i] = plane_point(s[i], t[i]);
        // Normal N = (b - a) x (c - a) in integers; orient3d(a, b, c, d) = -N . (d - a).
        std::int64_t u[3], v[3];
        for (int k = 0; k < 3; ++k) {
            u[k] = std::int64_t(p[1][k] - p[0][k]);
            v[k] = std::int64_t(p[2][k] - p[0][k]);
        }
        const std::int64_t normal[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2],
                                        u[0] * v[1] - u[1] * v[0]};
        for (int k : {-500, 0, 35, 500}) {
            for (int axis = 0; axis < 3; ++axis) {
                if (normal[axis] == 0) continue;
                const int expected = normal[axis] > 0 ? -1 : 1;
                P3 q[4];
                for (int i = 0; i < 4; ++i) q[i] = scaled(p[i], k);
                P3 up = q[3], down = q[3];
                up[axis] = std::nextafter(up[axis], std::numeric_limits<double>::infinity());
                down[axis] = std::nextafter(down[axis], -std::numeric_limits<double>::infinity());
                INFO("trial " << trial << " scale 2^" << k << " axis " << axis);
                CHECK(o3(q[0], q[1], q[2], up) == expected);
                CHECK(o3(q[0], q[1], q[2], down) == -expected);
                CHECK(o3(q[1], q[0], q[2], up) == -expected);
                CHECK(o3(up, q[0], q[2], q[1]) == expected);  // an even permutation
                ++tested;
            }
        }
        // The same with a translation by 2^40, where one ulp is 2^-12.
        const double shift = std::ldexp(1.0, 40);
        for (int axis = 0; axis < 3; ++axis) {
            if (normal[axis] == 0) continue;
            P3 q[4];
            for (int i = 0; i < 4; ++i) q[i] = shifted(p[i], shift);
            q[3][axis] = std::nextafter(q[3][axis], std::numeric_limits<double>::infinity());
            CHECK(o3(q[0], q[1], q[2], q[3]) == (normal[axis] > 0 ? -1 : 1));
        }
    }
    CHECK(tested > 1000);
}

TEST_CASE("orient3d matches __int128 on near-coplanar integer points", "[core]") {
    // b - a = e1 = (1, 0, p), c - a = e2 = (0, 1, q), d - a = i e1 + j e2 + delta: the exact
    // determinant is small (delta . (e1 x e2)) while the permanent is about 2^100, far beyond
    // what the floating-point filter can decide.
    std::mt19937_64 rng(13);
    std::uniform_int_distribution<std::int64_t> big(-(1ll << 29), 1ll << 29);
    std::uniform_int_distribution<std::int64_t> slope(-(1ll << 25), 1ll << 25);
    std::uniform_int_distribution<std::int64_t> small(-16, 16);
    std::uniform_int_distribution<int> unit(-1, 1);
    int naive_wrong = 0;
    for (int trial = 0; trial < 3000; ++trial) {
        const std::int64_t a[3] = {big(rng), big(rng), big(rng)};
        const std::int64_t p = slope(rng), q = slope(rng), i = small(rng), j = small(rng);
        const std::int64_t e1[3] = {1, 0, p}, e2[3] = {0, 1, q};
        const std::int64_t delta[3] = {trial % 3 == 0 ? unit(rng) : 0,
                                       trial % 3 == 0 ? unit(rng) : 0, unit(rng)};
        std::int64_t pts[4][3];
        for (int k = 0; k < 3; ++k) {
            pts[0][k] = a[k];
            pts[1][k] = a[k] + e1[k];
            pts[2][k] = a[k] + e2[k];
            pts[3][k] = a[k] + i * e1[k] + j * e2[k] + delta[k];
        }
        // A random unimodular map (unit lower times unit upper triangular, small entries)
        // keeps the points integral and mixes the small and large coordinates.
        std::int64_t lower[3] = {small(rng) % 3, small(rng) % 3, small(rng) % 3};
        std::int64_t upper[3] = {small(rng) % 3, small(rng) % 3, small(rng) % 3};
        std::int64_t w[4][3];
        P3 x[4];
        for (int r = 0; r < 4; ++r) {
            const std::int64_t* v = pts[r];
            const std::int64_t u[3] = {v[0] + upper[0] * v[1] + upper[1] * v[2],
                                       v[1] + upper[2] * v[2], v[2]};
            w[r][0] = u[0];
            w[r][1] = lower[0] * u[0] + u[1];
            w[r][2] = lower[1] * u[0] + lower[2] * u[1] + u[2];
            for (int k = 0; k < 3; ++k) x[r][k] = double(w[r][k]);
        }
        __int128 m[3][3];
        for (int r = 0; r < 3; ++r)
            for (int k = 0; k < 3; ++k) m[r][k] = __int128(w[r][k]) - w[3][k];
        const __int128 det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) +
                             m[0][1] * (m[1][2] * m[2][0] - m[1][0] * m[2][2]) +
                             m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
        const int expected = (det > 0) - (det < 0);
        INFO("trial " << trial);
        CHECK(o3(x[0], x[1], x[2], x[3]) == expected);
        CHECK(o3(x[2], x[3], x[0], x[1]) == expected);
        const double naive = naive_orient3d(x[0], x[1], x[2], x[3]);
        naive_wrong += ((naive > 0) - (naive < 0)) != expected;
    }
    CHECK(naive_wrong > 100);  // the input really is beyond plain doubles
}

TEST_CASE("orient3d matches big integers on rounded coplanar points", "[core]") {
    // d = a + s (b - a) + t (c - a) rounded: within a few ulps of the plane. Coordinates of
    // mixed magnitude make the differences inexact, which exercises the raw-coordinate path.
    std::mt19937_64 rng(14);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    std::uniform_int_distribution<int> exponent(-40, 40);
    int zeros = 0, positives = 0, negatives = 0;
    for (int trial = 0; trial < 1500; ++trial) {
        const double scale = std::ldexp(1.0, exponent(rng));
        const double offset = trial % 2 == 0 ? 0.0 : unit(rng) * std::ldexp(1.0, exponent(rng));
        P3 a, b, c, d;
        for (int k = 0; k < 3; ++k) {
            a[k] = offset + scale * unit(rng);
            b[k] = offset + scale * unit(rng) * (trial % 5 == 0 ? 1e-9 : 1.0);
            c[k] = offset + scale * unit(rng);
        }
        const double s = trial % 10 == 0 ? 0.0 : unit(rng), t = trial % 10 == 0 ? 0.0 : unit(rng);
        for (int k = 0; k < 3; ++k) d[k] = a[k] + s * (b[k] - a[k]) + t * (c[k] - a[k]);
        const int expected = reference_orient3d(a, b, c, d);
        INFO("trial " << trial);
        REQUIRE(o3(a, b, c, d) == expected);
        CHECK(o3(d, c, b, a) == expected);  // (0 3)(1 2): even
        zeros += expected == 0;
        positives += expected > 0;
        negatives += expected < 0;
    }
    CHECK(positives > 100);
    CHECK(negatives > 100);
    CHECK(zeros > 10);
}

TEST_CASE("orient3d is exact on mixed magnitudes in a coordinate plane", "[core]") {
    // Points in a plane z = const (and in x = y) with coordinates from 2^-30 to 2^60: exactly
    // coplanar, and one ulp off it; their differences are generally not doubles.
    std::mt19937_64 rng(15);
    std::uniform_int_distribution<std::int64_t> mantissa(1, (1ll << 53) - 1);
    std::uniform_int_distribution<int> exponent(-83, 7);
    std::uniform_int_distribution<int> coin(0, 1);
    auto value = [&]() {
        const double v = std::ldexp(double(mantissa(rng)), exponent(rng));
        return coin(rng) != 0 ? -v : v;
    };
    for (int trial = 0; trial < 1000; ++trial) {
        const bool diagonal = trial % 2 == 1;
        const double height = value();
        P3 p[4];
        for (auto& q : p) {
            q = {value(), value(), height};
            if (diagonal) q = {q[0], q[0], value()};
        }
        INFO("trial " << trial);
        CHECK(o3(p[0], p[1], p[2], p[3]) == 0);
        const int axis = diagonal ? 1 : 2;
        p[3][axis] = std::nextafter(p[3][axis], coin(rng) != 0 ? 1e300 : -1e300);
        CHECK(o3(p[0], p[1], p[2], p[3]) == reference_orient3d(p[0], p[1], p[2], p[3]));
    }
}

TEST_CASE("orient3d handles huge and tiny magnitudes", "[core]") {
    for (int k : {-900, -500, 500, 900}) {
        const P3 a = scaled({0, 0, 0}, k), b = scaled({1, 0, 0}, k), c = scaled({0, 1, 0}, k);
        CHECK(o3(a, b, c, scaled({0.25, 0.25, -0.5}, k)) == 1);
        CHECK(o3(a, b, c, scaled({0.25, 0.25, 0.5}, k)) == -1);
        CHECK(o3(a, b, c, scaled({3, -7, 0}, k)) == 0);
    }
    const double big = std::numeric_limits<double>::max() / 4;
    const P3 x{big, 0, 0}, y{0, big, 0}, z{0, 0, big}, o{0, 0, 0};
    CHECK(o3(x, y, z, o) == reference_orient3d(x, y, z, o));
    CHECK(o3(x, y, z, o) == 1);
    CHECK(o3({0, 0, 0}, {0, 0, 0}, {0, 0, 0}, {0, 0, 0}) == 0);
}

TEST_CASE("orient2d: convention, collinear points, one-ulp moves and rounded points", "[core]") {
    CHECK(o2({0, 0, 0}, {1, 0, 0}, {0, 1, 0}) == 1);
    CHECK(o2({0, 0, 0}, {0, 1, 0}, {1, 0, 0}) == -1);
    CHECK(o2({0, 0, 5}, {0, 1, 7}, {0, 0, 9}, 1, 2) == 1);
    CHECK(o2({0, 0, 5}, {0, 1, 7}, {0, 0, 9}, 2, 1) == -1);
    // The unused coordinate does not matter, even when huge.
    CHECK(o2({0, 0, 1e300}, {1, 0, -1e300}, {0, 1, 3}) == 1);

    std::mt19937_64 rng(21);
    std::uniform_int_distribution<std::int64_t> coef(-100000, 100000);
    for (int trial = 0; trial < 300; ++trial) {
        // Integer points on the line 3x - 5y = 1: (2, 1) + s (5, 3).
        P3 p[3];
        for (auto& q : p) {
            const std::int64_t s = coef(rng);
            q = {double(2 + 5 * s), 0.0, double(1 + 3 * s)};
        }
        INFO("trial " << trial);
        for (int k : {-700, 0, 700}) {
            P3 q[3] = {scaled(p[0], k), scaled(p[1], k), scaled(p[2], k)};
            CHECK(o2(q[0], q[1], q[2], 0, 2) == 0);
            if (p[0] == p[1]) continue;
            // orient2d(a, b, c) = cross(b - a, c - a); moving c along x changes it by -(b-a)_z h.
            const int dir_z = p[1][2] > p[0][2] ? 1 : -1;
            q[2][0] = std::nextafter(q[2][0], 1e308);
            CHECK(o2(q[0], q[1], q[2], 0, 2) == -dir_z);
            CHECK(o2(q[0], q[1], q[2], 2, 0) == dir_z);
        }
    }
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    std::uniform_int_distribution<int> exponent(-30, 30);
    for (int trial = 0; trial < 2000; ++trial) {
        const double offset = trial % 2 == 0 ? 0.0 : std::ldexp(unit(rng), exponent(rng));
        P3 a{offset + unit(rng), offset + unit(rng), 0},
            b{offset + unit(rng), offset + unit(rng), 0};
        const double t = unit(rng) * 4;
        P3 c{a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), 0};
        INFO("trial " << trial);
        CHECK(o2(a, b, c) == reference_orient2d(a, b, c, 0, 1));
        CHECK(o2(c, a, b) == reference_orient2d(a, b, c, 0, 1));
    }
}

TEST_CASE("insphere follows the documented sign convention", "[core]") {
    const P3 a{1, 1, 1}, b{1, -1, -1}, c{-1, 1, -1}, d{-1, -1, 1};  // a regular tetrahedron
    P3 v[4] = {a, b, c, d};
    if (o3(a, b, c, d) < 0) std::swap(v[0], v[1]);
    REQUIRE(o3(v[0], v[1], v[2], v[3]) > 0);
    CHECK(is(v[0], v[1], v[2], v[3], {0, 0, 0}) == 1);
    CHECK(is(v[0], v[1], v[2], v[3], {0.5, -0.2, 0.1}) == 1);
    CHECK(is(v[0], v[1], v[2], v[3], {3, 0, 0}) == -1);
    CHECK(is(v[0], v[1], v[2], v[3], {1, -1, 1}) == 0);  // a cube corner, on the sphere
    CHECK(is(v[1], v[0], v[2], v[3], {0, 0, 0}) == -1);  // negatively oriented: reversed
}

TEST_CASE("insphere is exact on cospherical integer points and one-ulp moves", "[core]") {
    // Lattice points on the sphere of radius 13 about the origin.
    std::vector<P3> sphere;
    for (const P3& base : {P3{3, 4, 12}, P3{0, 5, 12}, P3{13, 0, 0}})
        for (int perm = 0; perm < 6; ++perm)
            for (int signs = 0; signs < 8; ++signs) {
                static constexpr int orders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
                                                     {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
                P3 p;
                for (int k = 0; k < 3; ++k)
                    p[k] = base[orders[perm][k]] * ((signs >> k) & 1 ? -1 : 1);
                if (std::find(sphere.begin(), sphere.end(), p) == sphere.end()) sphere.push_back(p);
            }
    std::mt19937_64 rng(31);
    std::uniform_int_distribution<std::size_t> pick(0, sphere.size() - 1);
    int tested = 0;
    for (int trial = 0; trial < 400; ++trial) {
        P3 p[5];
        for (auto& q : p) q = sphere[pick(rng)];
        if (o3(p[0], p[1], p[2], p[3]) == 0) continue;
        if (o3(p[0], p[1], p[2], p[3]) < 0) std::swap(p[0], p[1]);
        const int axis = trial % 3;
        if (p[4][axis] == 0.0 || p[4] == p[0] || p[4] == p[1] || p[4] == p[2] || p[4] == p[3])
            continue;
        ++tested;
        for (int k : {-150, 0, 150}) {
            P3 q[5];
            for (int i = 0; i < 5; ++i) q[i] = scaled(p[i], k);
            INFO("trial " << trial << " scale 2^" << k);
            CHECK(is(q[0], q[1], q[2], q[3], q[4]) == 0);
            P3 out = q[4], in = q[4];
            const double away = q[4][axis] > 0 ? 1e308 : -1e308;
            out[axis] = std::nextafter(out[axis], away);
            in[axis] = std::nextafter(in[axis], -away);
            CHECK(is(q[0], q[1], q[2], q[3], out) == -1);
            CHECK(is(q[0], q[1], q[2], q[3], in) == 1);
            CHECK(is(q[1], q[0], q[2], q[3], in) == -1);
        }
        // Translated by 2^30: exact integers, the centre moves along.
        const double t = std::ldexp(1.0, 30);
        P3 q[5];
        for (int i = 0; i < 5; ++i) q[i] = shifted(p[i], t);
        CHECK(is(q[0], q[1], q[2], q[3], q[4]) == 0);
        q[4][axis] = std::nextafter(q[4][axis], p[4][axis] > 0 ? 1e308 : -1e308);
        CHECK(is(q[0], q[1], q[2], q[3], q[4]) == -1);
    }
    CHECK(tested > 100);
}

TEST_CASE("insphere matches big integers on rounded cospherical points", "[core]") {
    std::mt19937_64 rng(32);
    std::uniform_real_distribution<double> unit(-1.0, 1.0);
    std::uniform_int_distribution<int> exponent(-20, 20);
    std::normal_distribution<double> gauss;
    int inside = 0, outside = 0, on = 0;
    for (int trial = 0; trial < 1500; ++trial) {
        const double radius = std::ldexp(1.0 + unit(rng) * 0.5, exponent(rng));
        const P3 centre{unit(rng) * radius * (trial % 3), unit(rng) * radius * 100 * (trial % 2),
                        unit(rng)};
        P3 p[5];
        for (auto& q : p) {
            Eigen::Vector3d dir(gauss(rng), gauss(rng), gauss(rng));
            dir.normalize();
            for (int k = 0; k < 3; ++k) q[k] = centre[k] + radius * dir[k];
        }
        if (trial % 7 == 0) p[4] = p[trial % 4];  // on the sphere exactly
        if (trial % 11 == 0) {                    // one ulp off a point of the sphere
            p[4] = p[2];
            p[4][0] = std::nextafter(p[4][0], 1e308);
        }
        if (reference_orient3d(p[0], p[1], p[2], p[3]) == 0) continue;
        if (reference_orient3d(p[0], p[1], p[2], p[3]) < 0) std::swap(p[0], p[1]);
        const int expected = reference_insphere(p[0], p[1], p[2], p[3], p[4]);
        INFO("trial " << trial);
        REQUIRE(is(p[0], p[1], p[2], p[3], p[4]) == expected);
        CHECK(is(p[1], p[2], p[0], p[3], p[4]) == expected);  // even permutation
        inside += expected > 0;
        outside += expected < 0;
        on += expected == 0;
    }
    CHECK(inside > 100);
    CHECK(outside > 100);
    CHECK(on > 50);
}

// ---------------------------------------------------------------------------------------------
// Triangle and segment intersection.
// ---------------------------------------------------------------------------------------------
namespace {

using I3 = std::array<std::int64_t, 3>;
using Tri = std::array<I3, 3>;

I3 minus(const I3& a, const I3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
I3 cross(const I3& a, const I3& b) {
    return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
std::int64_t dot(const I3& a, const I3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
bool is_zero(const I3& a) { return a[0] == 0 && a[1] == 0 && a[2] == 0; }

// Independent reference: separating axes of the Minkowski difference A - B. Its facet normals
// are cross products of two edge directions; in-plane edge normals of a flat difference are
// (e_i x e_j) x e_k; a one-dimensional difference is separated along its direction or
// across it (direction x coordinate axis); a point along a coordinate axis. Closed sets meet
// iff no candidate axis separates them strictly.
bool reference_intersect(const Tri& a, const Tri& b) {
    std::vector<I3> directions = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    for (const Tri* t : {&a, &b})
        for (int k = 0; k < 3; ++k) directions.push_back(minus((*t)[(k + 1) % 3], (*t)[k]));
    std::vector<I3> axes = directions;
    for (const I3& u : directions)
        for (const I3& v : directions) {
            const I3 n = cross(u, v);
            if (is_zero(n)) continue;
            axes.push_back(n);
            for (const I3& w : directions) axes.push_back(cross(n, w));
        }
    for (const I3& axis : axes) {
        if (is_zero(axis)) continue;
        std::int64_t a_lo = INT64_MAX, a_hi = INT64_MIN, b_lo = INT64_MAX, b_hi = INT64_MIN;
        for (int k = 0; k < 3; ++k) {
            a_lo = std::min(a_lo, dot(axis, a[k]));
            a_hi = std::max(a_hi, dot(axis, a[k]));
            b_lo = std::min(b_lo, dot(axis, b[k]));
            b_hi = std::max(b_hi, dot(axis, b[k]));
        }
        if (a_hi < b_lo || b_hi < a_lo) return false;
    }
    return true;
}

P3 to_p3(const I3& p, double scale = 1.0, double shift = 0.0) {
    return {double(p[0]) * scale + shift, double(p[1]) * scale + shift,
            double(p[2]) * scale + shift};
}

bool tri_tri(const P3& a0, const P3& a1, const P3& a2, const P3& b0, const P3& b1, const P3& b2) {
    return triangles_intersect(a0.data(), a1.data(), a2.data(), b0.data(), b1.data(), b2.data());
}
bool seg_tri(const P3& p, const P3& q, const P3& a, const P3& b, const P3& c) {
    return segment_intersects_triangle(p.data(), q.data(), a.data(), b.data(), c.data());
}

// triangles_intersect with the given vertex orders; the answer for (a, b) in input order.
bool tri_tri_ordered(const Tri& a, const Tri& b, const int* oa, const int* ob, bool swap,
                     double scale, double shift) {
    const P3 pa[3] = {to_p3(a[oa[0]], scale, shift), to_p3(a[oa[1]], scale, shift),
                      to_p3(a[oa[2]], scale, shift)};
    const P3 pb[3] = {to_p3(b[ob[0]], scale, shift), to_p3(b[ob[1]], scale, shift),
                      to_p3(b[ob[2]], scale, shift)};
    return swap ? tri_tri(pb[0], pb[1], pb[2], pa[0], pa[1], pa[2])
                : tri_tri(pa[0], pa[1], pa[2], pb[0], pb[1], pb[2]);
}

// triangles_intersect in input order; checks that every vertex order of both triangles and
// both argument orders agree with it.
bool tri_tri_all_orders(const Tri& a, const Tri& b, double scale = 1.0, double shift = 0.0) {
    static constexpr int orders[6][3] = {{0, 1, 2}, {1, 2, 0}, {2, 0, 1},
                                         {0, 2, 1}, {2, 1, 0}, {1, 0, 2}};
    const bool first = tri_tri_ordered(a, b, orders[0], orders[0], false, scale, shift);
    int disagreements = 0;
    for (const auto& oa : orders)
        for (const auto& ob : orders)
            for (bool swap : {false, true})
                disagreements += tri_tri_ordered(a, b, oa, ob, swap, scale, shift) != first;
    CHECK(disagreements == 0);
    return first;
}

}  // namespace

TEST_CASE("triangles_intersect on named configurations", "[core]") {
    const Tri base{{{0, 0, 0}, {4, 0, 0}, {0, 4, 0}}};
    SECTION("crossing") { CHECK(tri_tri_all_orders(base, {{{1, 1, -1}, {1, 1, 1}, {5, 5, 0}}})); }
    SECTION("crossing through both interiors, non-axis-aligned") {
        CHECK(tri_tri_all_orders({{{0, 0, 0}, {6, 1, 2}, {1, 6, 3}}},
                                 {{{3, 3, -3}, {2, 2, 6}, {-4, 5, 1}}}) ==
              reference_intersect({{{0, 0, 0}, {6, 1, 2}, {1, 6, 3}}},
                                  {{{3, 3, -3}, {2, 2, 6}, {-4, 5, 1}}}));
    }
    SECTION("touching at a vertex") {
        CHECK(tri_tri_all_orders(base, {{{1, 1, 0}, {1, 1, 3}, {2, 3, 3}}}));   // in the interior
        CHECK(tri_tri_all_orders(base, {{{2, 0, 0}, {2, -1, 3}, {3, 0, 3}}}));  // on an edge
        CHECK(tri_tri_all_orders(base, {{{4, 0, 0}, {5, 1, 3}, {6, 0, 2}}}));   // vertex to vertex
    }
    SECTION("missing a vertex or an edge by one unit") {
        CHECK_FALSE(tri_tri_all_orders(base, {{{1, 1, 1}, {1, 1, 3}, {2, 3, 3}}}));
        CHECK_FALSE(tri_tri_all_orders(base, {{{3, 2, -1}, {3, 2, 1}, {6, 6, 0}}}));
    }
    SECTION("sharing an edge") {
        CHECK(tri_tri_all_orders(base, {{{0, 0, 0}, {4, 0, 0}, {1, 2, 5}}}));
        CHECK(tri_tri_all_orders(base, {{{0, 0, 0}, {4, 0, 0}, {1, -2, 0}}}));  // coplanar
    }
    SECTION("coplanar overlap, containment, touching and disjoint") {
        CHECK(tri_tri_all_orders(base, {{{1, 1, 0}, {5, 1, 0}, {1, 5, 0}}}));
        CHECK(tri_tri_all_orders(base, {{{1, 1, 0}, {2, 1, 0}, {1, 2, 0}}}));      // inside
        CHECK(tri_tri_all_orders(base, {{{-1, -1, 0}, {9, -1, 0}, {-1, 9, 0}}}));  // around
        CHECK(tri_tri_all_orders(base, {{{2, 2, 0}, {5, 2, 0}, {2, 5, 0}}}));      // vertex on edge
        CHECK(tri_tri_all_orders(base, {{{4, 4, 0}, {2, 2, 0}, {4, 2, 0}}}));  // touching at (2, 2)
        CHECK_FALSE(tri_tri_all_orders(base, {{{3, 3, 0}, {5, 3, 0}, {3, 5, 0}}}));
        CHECK_FALSE(tri_tri_all_orders(base, {{{5, 0, 0}, {9, 0, 0}, {5, 4, 0}}}));
    }
    SECTION("parallel planes") {
        CHECK_FALSE(tri_tri_all_orders(base, {{{0, 0, 1}, {4, 0, 1}, {0, 4, 1}}}));
        CHECK_FALSE(tri_tri_all_orders(base, {{{0, 0, -1}, {9, 0, -1}, {0, 9, -1}}}));
    }
    SECTION("degenerate triangles") {
        CHECK(tri_tri_all_orders(base, {{{1, 1, -2}, {1, 1, 2}, {1, 1, 0}}}));  // a segment through
        CHECK(tri_tri_all_orders(base, {{{1, 1, 0}, {1, 1, 0}, {1, 1, 0}}}));   // a point inside
        CHECK_FALSE(tri_tri_all_orders(base, {{{3, 3, 0}, {3, 3, 0}, {3, 3, 0}}}));
        CHECK(tri_tri_all_orders(base, {{{-1, 2, 0}, {5, 2, 0}, {1, 2, 0}}}));   // segment in plane
        CHECK(tri_tri_all_orders(base, {{{-2, 5, 0}, {5, -2, 0}, {0, 3, 0}}}));  // across
        CHECK(tri_tri_all_orders({{{0, 0, 0}, {2, 2, 2}, {1, 1, 1}}},
                                 {{{2, 0, 0}, {0, 2, 2}, {0, 2, 2}}}));
        CHECK_FALSE(tri_tri_all_orders({{{0, 0, 0}, {2, 2, 2}, {1, 1, 1}}},
                                       {{{2, 0, 0}, {0, 2, 3}, {0, 2, 3}}}));
        CHECK(tri_tri_all_orders({{{0, 0, 0}, {2, 2, 2}, {0, 0, 0}}},
                                 {{{1, 1, 1}, {3, 3, 3}, {3, 3, 3}}}));
        CHECK_FALSE(tri_tri_all_orders({{{0, 0, 0}, {2, 2, 2}, {0, 0, 0}}},
                                       {{{3, 3, 3}, {5, 5, 5}, {4, 4, 4}}}));
    }
}

TEST_CASE("triangles_intersect matches separating axes on random lattice triangles", "[core]") {
    // A 4x4x4 lattice makes coplanar, collinear and touching cases common.
    std::mt19937_64 rng(41);
    for (int range : {2, 4}) {
        std::uniform_int_distribution<std::int64_t> coord(0, range - 1);
        int hits = 0, misses = 0;
        for (int trial = 0; trial < 2500; ++trial) {
            Tri a, b;
            for (auto& p : a) p = {coord(rng), coord(rng), coord(rng)};
            for (auto& p : b) p = {coord(rng), coord(rng), coord(rng)};
            if (trial % 4 == 0)  // flatten both into z = 1: coplanar cases
                for (Tri* t : {&a, &b})
                    for (auto& p : *t) p[2] = 1;
            const bool expected = reference_intersect(a, b);
            INFO("trial " << trial << " range " << range);
            CHECK(tri_tri_all_orders(a, b) == expected);
            // Exact similarity transforms keep the answer: power-of-two scale and a shift.
            CHECK(tri_tri_all_orders(a, b, 0.125, 1024.5) == expected);
            (expected ? hits : misses)++;
        }
        CHECK(hits > 300);
        CHECK(misses > 300);
    }
}

TEST_CASE("segment_intersects_triangle on named and random lattice cases", "[core]") {
    const P3 a{0, 0, 0}, b{4, 0, 0}, c{0, 4, 0};
    CHECK(seg_tri({1, 1, -1}, {1, 1, 1}, a, b, c));         // crossing
    CHECK(seg_tri({1, 1, 0}, {1, 1, 1}, a, b, c));          // endpoint on the triangle
    CHECK(seg_tri({2, 2, -1}, {2, 2, 1}, a, b, c));         // through an edge
    CHECK(seg_tri({0, 0, -1}, {0, 0, 1}, a, b, c));         // through a vertex
    CHECK_FALSE(seg_tri({3, 3, -1}, {3, 3, 1}, a, b, c));   // passing outside
    CHECK_FALSE(seg_tri({1, 1, 1}, {1, 1, 2}, a, b, c));    // stopping short
    CHECK_FALSE(seg_tri({1, 1, 1}, {3, 0, 1}, a, b, c));    // parallel
    CHECK(seg_tri({-1, 1, 0}, {5, 1, 0}, a, b, c));         // coplanar across
    CHECK(seg_tri({1, 1, 0}, {1, 2, 0}, a, b, c));          // coplanar inside
    CHECK_FALSE(seg_tri({-1, 6, 0}, {6, -1, 0}, a, b, c));  // coplanar, beyond the hypotenuse
    CHECK(seg_tri({-2, 6, 0}, {6, -2, 0}, a, b, c));        // coplanar, along the hypotenuse
    CHECK(seg_tri({1, 1, 0}, {1, 1, 0}, a, b, c));          // a point
    CHECK(seg_tri({-1, 0, 0}, {9, 0, 0}, a, b, c));         // along an edge line
    CHECK(seg_tri({1, 1, -1}, {1, 1, 1}, {0, 0, 0}, {2, 2, 0}, {3, 3, 0}));  // collinear triangle
    CHECK_FALSE(seg_tri({1, 2, -1}, {1, 2, 1}, {0, 0, 0}, {2, 2, 0}, {3, 3, 0}));

    std::mt19937_64 rng(42);
    std::uniform_int_distribution<std::int64_t> coord(0, 3);
    int hits = 0;
    for (int trial = 0; trial < 20000; ++trial) {
        Tri t, s;
        for (auto& p : t) p = {coord(rng), coord(rng), coord(rng)};
        s[0] = {coord(rng), coord(rng), coord(rng)};
        s[1] = s[2] = {coord(rng), coord(rng), coord(rng)};
        if (trial % 3 == 0)
            for (Tri* x : {&t, &s})
                for (auto& p : *x) p[1] = 2;
        const bool expected = reference_intersect(s, t);
        INFO("trial " << trial);
        const P3 p = to_p3(s[0]), q = to_p3(s[1]);
        const P3 v[3] = {to_p3(t[0]), to_p3(t[1]), to_p3(t[2])};
        CHECK(seg_tri(p, q, v[0], v[1], v[2]) == expected);
        CHECK(seg_tri(q, p, v[2], v[0], v[1]) == expected);
        CHECK(seg_tri(p, q, v[1], v[0], v[2]) == expected);
        hits += expected;
    }
    CHECK(hits > 2000);
}

TEST_CASE("is_degenerate_triangle is exact", "[core]") {
    const P3 a{0.1, 0.2, 0.3};
    P3 b{0.1 * 3, 0.2 * 3, 0.3 * 3}, c{a[0] + 1, a[1] + 1, a[2] + 1};
    CHECK(is_degenerate_triangle(a.data(), a.data(), a.data()));
    CHECK(is_degenerate_triangle(a.data(), a.data(), b.data()));
    const P3 p{1, 2, 3}, q{3, 6, 9}, r{-2, -4, -6};
    CHECK(is_degenerate_triangle(p.data(), q.data(), r.data()));
    P3 r2 = r;
    r2[2] = std::nextafter(r2[2], 0.0);
    CHECK_FALSE(is_degenerate_triangle(p.data(), q.data(), r2.data()));
    CHECK(is_degenerate_triangle(a.data(), b.data(), c.data()) ==
          (reference_orient2d(a, b, c, 0, 1) == 0 && reference_orient2d(a, b, c, 1, 2) == 0 &&
           reference_orient2d(a, b, c, 2, 0) == 0));
}

#include "pipeline/core/surface_network.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <map>
#include <numeric>
#include <tuple>

namespace frontmesh::core {

void vertex_faces(const SurfaceNetwork& surface, std::vector<std::int32_t>& offsets,
                  std::vector<std::int32_t>& faces) {
    const std::size_t n = surface.vertex_count();
    offsets.assign(n + 1, 0);
    for (const auto& t : surface.faces)
        for (const auto v : t) ++offsets[std::size_t(v) + 1];
    for (std::size_t v = 0; v < n; ++v) offsets[v + 1] += offsets[v];
    faces.assign(std::size_t(offsets[n]), -1);
    std::vector<std::int32_t> fill(offsets.begin(), offsets.end() - 1);
    for (std::size_t f = 0; f < surface.face_count(); ++f)
        for (const auto v : surface.faces[f])
            faces[std::size_t(fill[std::size_t(v)]++)] = static_cast<std::int32_t>(f);
}

std::vector<Label> region_labels(const SurfaceNetwork& surface) {
    std::vector<Label> labels;
    labels.reserve(surface.face_count() * 2);
    for (Label l : surface.region_in) labels.push_back(l);
    for (Label l : surface.region_out) labels.push_back(l);
    std::sort(labels.begin(), labels.end());
    labels.erase(std::unique(labels.begin(), labels.end()), labels.end());
    labels.erase(std::remove(labels.begin(), labels.end(), 0), labels.end());
    return labels;
}

double enclosed_volume(const SurfaceNetwork& surface, Label region) {
    // Divergence theorem: V = sum over outward faces of (a . (b x c)) / 6, the points taken
    // from a vertex of the surface (any point gives the same V for a closed boundary): from
    // the origin, terms of |x|^3 cancelled, and an image 900 m from its origin gave a
    // region of -150 mm^3 (exit 1 in repair; the malformed-input campaign, issue 21).
    const Eigen::Vector3d o =
        surface.vertex_count() > 0 ? Eigen::Vector3d(surface.point(0)) : Eigen::Vector3d::Zero();
    double six_v = 0.0;
    for (std::size_t f = 0; f < surface.face_count(); ++f) {
        const double sign = surface.region_in[f] == region    ? 1.0
                            : surface.region_out[f] == region ? -1.0
                                                              : 0.0;
        if (sign == 0.0) continue;
        const auto& t = surface.faces[f];
        six_v +=
            sign *
            (surface.point(t[0]) - o).dot((surface.point(t[1]) - o).cross(surface.point(t[2]) - o));
    }
    return six_v / 6.0;
}

std::vector<RegionBoundaryCheck> check_region_boundaries(const SurfaceNetwork& surface) {
    // One record per (region, directed edge as seen outward from that region).
    struct EdgeUse {
        Label region;
        std::int32_t lo, hi;
        std::int8_t forward;  // +1 traversed lo->hi, -1 hi->lo
        bool operator<(const EdgeUse& o) const {
            return std::tie(region, lo, hi, forward) < std::tie(o.region, o.lo, o.hi, o.forward);
        }
    };
    std::vector<EdgeUse> uses;
    uses.reserve(surface.face_count() * 6);
    std::map<Label, RegionBoundaryCheck> checks;
    for (std::size_t f = 0; f < surface.face_count(); ++f) {
        const auto& t = surface.faces[f];
        for (int side = 0; side < 2; ++side) {
            const Label region = side == 0 ? surface.region_in[f] : surface.region_out[f];
            if (region == 0) continue;
            checks[region].region = region;
            ++checks[region].faces;
            for (int i = 0; i < 3; ++i) {
                std::int32_t a = t[i], b = t[(i + 1) % 3];
                if (side == 1) std::swap(a, b);  // reversed as seen from region_out
                uses.push_back({region, std::min(a, b), std::max(a, b),
                                static_cast<std::int8_t>(a < b ? 1 : -1)});
            }
        }
    }
    std::sort(uses.begin(), uses.end());
    for (std::size_t i = 0; i < uses.size();) {
        std::size_t j = i;
        int forward = 0, backward = 0;
        while (j < uses.size() && uses[j].region == uses[i].region && uses[j].lo == uses[i].lo &&
               uses[j].hi == uses[i].hi) {
            (uses[j].forward > 0 ? forward : backward)++;
            ++j;
        }
        auto& check = checks[uses[i].region];
        const int total = forward + backward;
        if (total % 2 != 0)
            ++check.open_edges;
        else if (forward != backward)
            ++check.misoriented_edges;
        if (total > 2) ++check.nonmanifold_edges;
        i = j;
    }
    std::vector<RegionBoundaryCheck> result;
    for (auto& [region, check] : checks) {
        check.volume = enclosed_volume(surface, region);
        result.push_back(check);
    }
    return result;
}

namespace {

// The solid angle of triangle abc seen from p over 4 pi, signed: positive when p is behind it
// (Van Oosterom and Strackee's formula); a closed outward surface sums to 1 inside, 0 outside.
double winding_of(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                  const Eigen::Vector3d& c) {
    const Eigen::Vector3d u = a - p, v = b - p, w = c - p;
    const double lu = u.norm(), lv = v.norm(), lw = w.norm();
    const double num = u.dot(v.cross(w));
    const double den = lu * lv * lw + u.dot(v) * lw + v.dot(w) * lu + w.dot(u) * lv;
    return std::atan2(num, den) / (2.0 * 3.14159265358979323846);
}

}  // namespace

std::vector<InvertedPart> inverted_parts(const SurfaceNetwork& surface) {
    // Each (region, face) as seen from the region, outward: region_out faces reversed.
    struct Side {
        Label region;
        std::int32_t face;
        bool reversed;
    };
    std::vector<Side> sides;
    for (std::size_t f = 0; f < surface.face_count(); ++f) {
        sides.push_back({surface.region_in[f], std::int32_t(f), false});
        if (surface.region_out[f] != 0)
            sides.push_back({surface.region_out[f], std::int32_t(f), true});
    }
    // Parts: union-find over the sides of one region sharing an edge.
    struct EdgeUse {
        Label region;
        std::int32_t lo, hi;
        std::int32_t side;
        bool operator<(const EdgeUse& o) const {
            return std::tie(region, lo, hi, side) < std::tie(o.region, o.lo, o.hi, o.side);
        }
    };
    std::vector<EdgeUse> uses;
    uses.reserve(sides.size() * 3);
    for (std::size_t s = 0; s < sides.size(); ++s) {
        const auto& t = surface.faces[std::size_t(sides[s].face)];
        for (int i = 0; i < 3; ++i)
            uses.push_back({sides[s].region, std::min(t[i], t[(i + 1) % 3]),
                            std::max(t[i], t[(i + 1) % 3]), std::int32_t(s)});
    }
    std::sort(uses.begin(), uses.end());
    std::vector<std::int32_t> parent(sides.size());
    std::iota(parent.begin(), parent.end(), 0);
    auto root = [&](std::int32_t s) {
        while (parent[std::size_t(s)] != s)
            s = parent[std::size_t(s)] = parent[std::size_t(parent[std::size_t(s)])];
        return s;
    };
    for (std::size_t i = 1; i < uses.size(); ++i) {
        const EdgeUse &a = uses[i - 1], &b = uses[i];
        if (a.region != b.region || a.lo != b.lo || a.hi != b.hi) continue;
        const std::int32_t ra = root(a.side), rb = root(b.side);
        if (ra != rb) parent[std::size_t(std::max(ra, rb))] = std::min(ra, rb);
    }
    struct Part {
        Label region = 0;
        std::vector<std::int32_t> sides;
        Eigen::Vector3d lo, hi;
    };
    std::map<std::int32_t, Part> by_root;  // ordered by the first side: deterministic
    for (std::size_t s = 0; s < sides.size(); ++s) {
        Part& part = by_root[root(std::int32_t(s))];
        part.region = sides[s].region;
        part.sides.push_back(std::int32_t(s));
    }
    std::map<Label, std::vector<Part>> parts;
    for (auto& [r, part] : by_root) {
        part.lo = Eigen::Vector3d::Constant(INFINITY);
        part.hi = Eigen::Vector3d::Constant(-INFINITY);
        for (const std::int32_t s : part.sides)
            for (const std::int32_t v : surface.faces[std::size_t(sides[std::size_t(s)].face)]) {
                part.lo = part.lo.cwiseMin(surface.point(v));
                part.hi = part.hi.cwiseMax(surface.point(v));
            }
        parts[part.region].push_back(std::move(part));
    }
    auto corners = [&](const Side& side) {
        const auto& t = surface.faces[std::size_t(side.face)];
        std::array<Eigen::Vector3d, 3> x{surface.point(t[0]), surface.point(t[1]),
                                         surface.point(t[2])};
        if (side.reversed) std::swap(x[1], x[2]);
        return x;
    };
    std::vector<InvertedPart> inverted;
    for (const auto& [region, list] : parts) {
        if (list.size() < 2) continue;  // one part: its volume's sign says it all
        for (const Part& part : list) {
            // Just behind the largest face, by a small fraction of its size: no other face
            // of the region lies between (the part's thickness is far larger than this).
            std::int32_t best = part.sides.front();
            double best_area = -1.0;
            for (const std::int32_t s : part.sides) {
                const auto x = corners(sides[std::size_t(s)]);
                const double area = (x[1] - x[0]).cross(x[2] - x[0]).norm();
                if (area > best_area) best_area = area, best = s;
            }
            const auto x = corners(sides[std::size_t(best)]);
            const Eigen::Vector3d n = (x[1] - x[0]).cross(x[2] - x[0]);
            if (!(n.norm() > 0.0)) continue;  // degenerate: other checks name it
            const Eigen::Vector3d p =
                (x[0] + x[1] + x[2]) / 3.0 - 1e-4 * std::sqrt(n.norm()) * n.normalized();
            double w = 0.0;
            for (const Part& other : list) {
                if (&other != &part &&
                    ((p - other.lo).minCoeff() < 0.0 || (other.hi - p).minCoeff() < 0.0))
                    continue;  // outside its bounding box: it adds 0
                for (const std::int32_t s : other.sides) {
                    const auto y = corners(sides[std::size_t(s)]);
                    w += winding_of(p, y[0], y[1], y[2]);
                }
            }
            if (std::abs(w - 1.0) <= 0.5) continue;
            InvertedPart bad;
            bad.region = region;
            for (const std::int32_t s : part.sides) bad.faces.push_back(sides[std::size_t(s)].face);
            std::sort(bad.faces.begin(), bad.faces.end());
            bad.place = p;
            bad.winding = w;
            inverted.push_back(std::move(bad));
        }
    }
    return inverted;
}

}  // namespace frontmesh::core

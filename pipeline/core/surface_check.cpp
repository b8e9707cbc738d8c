#include "pipeline/core/surface_check.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <sstream>
#include <tuple>
#include <vector>

#include "pipeline/core/error.h"
#include "pipeline/core/predicates.h"
#include "pipeline/core/self_intersection.h"

namespace frontmesh::core {
namespace {

std::string near(const Eigen::Vector3d& p) {
    std::ostringstream s;
    s.precision(6);
    s << "near (" << p.x() << ", " << p.y() << ", " << p.z() << ") mm";
    return s.str();
}

[[noreturn]] void defect(const std::string& source, const std::string& what) {
    FM_THROW(InputError, source + ": " + what);
}

void require_valid_faces(const SurfaceNetwork& s, const std::string& source) {
    const auto n = static_cast<std::int64_t>(s.vertex_count());
    for (std::size_t v = 0; v < s.vertex_count(); ++v)
        if (!s.point(std::int32_t(v)).allFinite())
            defect(source, "vertex " + std::to_string(v) + " has a non-finite coordinate");
    if (s.face_count() == 0) defect(source, "the surface has no triangles");
    for (std::size_t f = 0; f < s.face_count(); ++f) {
        const auto& t = s.faces[f];
        for (const auto v : t)
            if (v < 0 || v >= n)
                defect(source, "face " + std::to_string(f) + " names vertex " + std::to_string(v) +
                                   ", but there are " + std::to_string(n) + " vertices");
        const std::string where = "face " + std::to_string(f) + " " + near(s.point(t[0]));
        if (s.region_in[f] <= 0)
            defect(source, where + ": region_in is " + std::to_string(s.region_in[f]) +
                               "; it must be a positive label (the region behind the face)");
        if (s.region_out[f] < 0 || s.region_out[f] == s.region_in[f])
            defect(source, where + ": region_out is " + std::to_string(s.region_out[f]) +
                               "; it must be 0 (outside) or another region than region_in " +
                               std::to_string(s.region_in[f]));
        if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
            defect(source,
                   where + " (region " + std::to_string(s.region_in[f]) + ") repeats a vertex");
        if (is_degenerate_triangle(s.point(t[0]).data(), s.point(t[1]).data(),
                                   s.point(t[2]).data()))
            defect(source, where + " (region " + std::to_string(s.region_in[f]) +
                               ") has zero area: its vertices are collinear");
    }
}

// Each region's boundary, seen from the region (region_out faces reversed): every edge has
// an even number of faces, alternating in direction (as many lo->hi as hi->lo).
void require_closed_regions(const SurfaceNetwork& s, const std::string& source) {
    struct Use {
        Label region;
        std::int32_t lo, hi;
        int forward;
        bool operator<(const Use& o) const {
            return std::tie(region, lo, hi, forward) < std::tie(o.region, o.lo, o.hi, o.forward);
        }
    };
    std::vector<Use> uses;
    uses.reserve(s.face_count() * 6);
    for (std::size_t f = 0; f < s.face_count(); ++f)
        for (int side = 0; side < 2; ++side) {
            const Label region = side == 0 ? s.region_in[f] : s.region_out[f];
            if (region == 0) continue;
            for (int i = 0; i < 3; ++i) {
                std::int32_t a = s.faces[f][i], b = s.faces[f][(i + 1) % 3];
                if (side == 1) std::swap(a, b);
                uses.push_back({region, std::min(a, b), std::max(a, b), a < b ? 1 : -1});
            }
        }
    std::sort(uses.begin(), uses.end());
    for (std::size_t i = 0; i < uses.size();) {
        std::size_t j = i;
        int balance = 0;
        for (; j < uses.size() && uses[j].region == uses[i].region && uses[j].lo == uses[i].lo &&
               uses[j].hi == uses[i].hi;
             ++j)
            balance += uses[j].forward;
        const std::size_t count = j - i;
        if (count % 2 != 0 || balance != 0) {
            const Eigen::Vector3d mid = 0.5 * (s.point(uses[i].lo) + s.point(uses[i].hi));
            defect(source, std::string(count % 2 != 0 ? "open" : "misoriented") +
                               " boundary of region " + std::to_string(uses[i].region) +
                               " at edge (" + std::to_string(uses[i].lo) + ", " +
                               std::to_string(uses[i].hi) + ") with " + std::to_string(count) +
                               " face(s) " + near(mid) +
                               (count % 2 != 0 ? ": the surface must be closed"
                                               : ": neighbouring faces point opposite ways"));
        }
        i = j;
    }
    for (const Label region : region_labels(s)) {
        const double volume = enclosed_volume(s, region);
        if (!(volume > 0.0)) {
            std::size_t f = 0;
            while (s.region_in[f] != region && s.region_out[f] != region) ++f;
            std::ostringstream v;
            v << volume;
            defect(source, "region " + std::to_string(region) + " encloses " + v.str() + " mm^3 " +
                               near(s.point(s.faces[f][0])) +
                               ": its faces point into it; they must point out of region_in");
        }
    }
}

}  // namespace

void require_meshable_surface(const SurfaceNetwork& surface, const std::string& source) {
    require_valid_faces(surface, source);
    require_closed_regions(surface, source);
    if (const auto inverted = inverted_parts(surface); !inverted.empty()) {
        const InvertedPart& part = inverted.front();
        std::ostringstream w;
        w.precision(3);
        w << part.winding;
        defect(source, "region " + std::to_string(part.region) + ": a part of its boundary (" +
                           std::to_string(part.faces.size()) + " faces, e.g. face " +
                           std::to_string(part.faces.front()) + ") is turned inside out " +
                           near(part.place) + ": the region's winding number behind it is " +
                           w.str() + ", not 1 (its faces must point out of region_in)");
    }
    const auto pairs = self_intersections(surface, 1);
    if (!pairs.empty()) {
        const auto [f, g] = pairs.front();
        const auto& t = surface.faces[std::size_t(f)];
        const Eigen::Vector3d c =
            (surface.point(t[0]) + surface.point(t[1]) + surface.point(t[2])) / 3.0;
        defect(source, "faces " + std::to_string(f) + " (region " +
                           std::to_string(surface.region_in[std::size_t(f)]) + ") and " +
                           std::to_string(g) + " (region " +
                           std::to_string(surface.region_in[std::size_t(g)]) + ") intersect " +
                           near(c) + "; the surface must not cross itself");
    }
}

}  // namespace frontmesh::core

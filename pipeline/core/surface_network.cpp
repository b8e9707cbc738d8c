#include "pipeline/core/surface_network.h"

#include <algorithm>
#include <cstdint>
#include <map>
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
    // Divergence theorem: V = sum over outward faces of (a . (b x c)) / 6.
    double six_v = 0.0;
    for (std::size_t f = 0; f < surface.face_count(); ++f) {
        const double sign = surface.region_in[f] == region    ? 1.0
                            : surface.region_out[f] == region ? -1.0
                                                              : 0.0;
        if (sign == 0.0) continue;
        const auto& t = surface.faces[f];
        six_v += sign * surface.point(t[0]).dot(surface.point(t[1]).cross(surface.point(t[2])));
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

}  // namespace frontmesh::core

// RetryPolicy of the remesh stage: every size multiplier applied across rounds, in one place
// (issue 19). The formulas are in surface/remesh_internal.h beside the class.

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

#include "surface/remesh_internal.h"

namespace frontmesh::surface::remesh_detail {

RetryPolicy::RetryPolicy(const core::SurfaceNetwork& background, const SizeField& field,
                         std::size_t patches)
    : background_(background),
      field_(field),
      face_scale_(background.face_count(), 1.0),
      vertex_scale_(background.vertex_count(), 1.0),
      rescaled_(patches, 0),
      patch_stalls_(patches, 0),
      patch_crossings_(patches, 0),
      copy_patch_(patches, 0) {}

double RetryPolicy::shrink(const Eigen::Vector3d& x) const {
    double scale = 1.0, round_factor = 1.0;
    int generation = -1;
    for (const ShrinkSite& site : shrink_sites_) {
        if (site.generation != generation) {  // a new round's sites: the last round's factor
            scale *= round_factor;
            round_factor = 1.0;
            generation = site.generation;
        }
        const double d = (x - site.centre).norm(), r = site.radius;
        if (d < 2.0 * r)
            round_factor = std::min(round_factor, d <= r ? 0.5 : 0.5 + 0.5 * (d - r) / r);
    }
    return std::max(scale * round_factor, 0.125);
}

double RetryPolicy::size(const Eigen::Vector3d& x, std::int32_t face) const {
    return field_.at(x, face) * shrink(x) * (face >= 0 ? face_scale_[std::size_t(face)] : 1.0);
}

double RetryPolicy::vertex_size(std::int32_t v) const {
    return field_.at_vertex(v) * shrink(background_.point(v)) * vertex_scale_[std::size_t(v)];
}

SizeFunction RetryPolicy::size_function() const {
    return [this](const Eigen::Vector3d& x, std::int32_t face) { return size(x, face); };
}

bool RetryPolicy::has_new_sizes(std::size_t p, const core::AdtBox& box) const {
    if (rescaled_[p]) return true;
    for (std::size_t k = sites_used_; k < shrink_sites_.size(); ++k) {
        const Eigen::Vector3d& c = shrink_sites_[k].centre;
        const double r = shrink_sites_[k].radius;
        double d2 = 0.0;  // squared distance from c to the box
        for (int i = 0; i < 3; ++i) {
            const double lo = box.lo[i], hi = box.hi[i];
            const double t = c[i] < lo ? lo - c[i] : c[i] > hi ? c[i] - hi : 0.0;
            d2 += t * t;
        }
        if (!(d2 >= 4.0 * r * r)) return true;  // shrink() is 1 beyond 2r
    }
    return false;
}

void RetryPolicy::mark_sizes_used() {
    sites_used_ = shrink_sites_.size();
    ++generation_;
    std::fill(rescaled_.begin(), rescaled_.end(), 0);
}

bool RetryPolicy::spend(double expected_triangles) {
    if (first_work_ == 0.0) first_work_ = std::max(expected_triangles, 1.0);
    work_ += expected_triangles;
    if (frugal_ || work_ <= kWorkBudget * first_work_) return false;
    frugal_ = true;
    return true;
}

void RetryPolicy::add_shrink_site(const Eigen::Vector3d& centre, double radius_in_h) {
    shrink_sites_.push_back({centre, radius_in_h * field_.at(centre, -1), generation_});
}

void RetryPolicy::on_stall(std::size_t p, const Eigen::Vector3d& place, int round) {
    // From the second-to-last round on, a finer size has no round left to prove itself: the
    // patch keeps its background triangles at once, so the last round cannot stall there.
    if (++patch_stalls_[p] >= 2 || round + 2 >= kRounds || frugal_) {
        copy_patch_[p] = 1;
        return;
    }
    add_shrink_site(place, 4.0);
}

void RetryPolicy::on_open_edges(const std::vector<Eigen::Vector3d>& midpoints) {
    for (const Eigen::Vector3d& m : midpoints) add_shrink_site(m, 2.0);
}

void RetryPolicy::on_bad_faces(const std::vector<std::int32_t>& faces,
                               const core::SurfaceNetwork& out,
                               const std::vector<std::int32_t>& face_patch, int round) {
    std::set<std::int32_t> bad;
    for (const std::int32_t face : faces) bad.insert(face_patch[std::size_t(face)]);
    // As for stalls: from the second-to-last round on, finer sizes would be tried in the last
    // round, where a stall they cause is the error; the bad patches are copied instead.
    for (const std::int32_t q : bad)
        if (++patch_crossings_[std::size_t(q)] >= 3 || round + 2 >= kRounds || frugal_)
            copy_patch_[std::size_t(q)] = 1;
    for (const std::int32_t face : faces) {
        if (copy_patch_[std::size_t(face_patch[std::size_t(face)])]) continue;
        const auto& t = out.faces[std::size_t(face)];
        const Eigen::Vector3d c = (out.point(t[0]) + out.point(t[1]) + out.point(t[2])) / 3.0;
        add_shrink_site(c, 2.0);
    }
}

void RetryPolicy::on_volume_change(const Features& features, core::Label region,
                                   double change_percent, double limit_percent) {
    // Chords lose volume as h^2: scale the sizes of the region's patches by about
    // sqrt(limit / change), with a margin.
    const double factor =
        std::clamp(0.9 * std::sqrt(limit_percent / std::abs(change_percent)), 0.5, 0.9);
    for (std::size_t p = 0; p < features.patches.size(); ++p) {
        const Patch& patch = features.patches[p];
        if (patch.region_in != region && patch.region_out != region) continue;
        rescaled_[p] = 1;
        for (const std::int32_t f : patch.faces) face_scale_[std::size_t(f)] *= factor;
    }
}

void RetryPolicy::on_collapsed_region(const Features& features, core::Label region) {
    for (std::size_t p = 0; p < features.patches.size(); ++p) {
        const Patch& patch = features.patches[p];
        if (patch.region_in != region && patch.region_out != region) continue;
        rescaled_[p] = 1;
        for (const std::int32_t f : patch.faces) face_scale_[std::size_t(f)] *= 0.5;
    }
    update_vertex_scales();
}

void RetryPolicy::update_vertex_scales() {
    for (std::size_t f = 0; f < background_.face_count(); ++f)
        for (const std::int32_t v : background_.faces[f])
            vertex_scale_[std::size_t(v)] = std::min(vertex_scale_[std::size_t(v)], face_scale_[f]);
}

void RetryPolicy::note(const std::string& trigger) {
    if (!triggers_.empty()) triggers_.append("; ");
    triggers_.append(trigger);
}

std::string RetryPolicy::round_summary(int round) {
    const double min_volume_scale = *std::min_element(face_scale_.begin(), face_scale_.end());
    const auto copied = std::count(copy_patch_.begin(), copy_patch_.end(), 1);
    std::ostringstream s;
    s << "remesh: round " << round + 1 << " of at most " << kRounds << " ("
      << (triggers_.empty() ? "first round" : triggers_) << "): h = size field x shrink ("
      << shrink_sites_.size()
      << " sites, x0.5 within r per round, at least x0.125) x volume scale (smallest x"
      << min_volume_scale << ") [x0.85 per failed attempt of a patch]; " << copied
      << " patch(es) keep their background triangles";
    triggers_.clear();
    return s.str();
}

}  // namespace frontmesh::surface::remesh_detail

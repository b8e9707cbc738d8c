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
      copy_patch_(patches, 0) {
    core::AdtBox domain = core::AdtBox::of_point(background.point(0));
    for (std::size_t v = 1; v < background.vertex_count(); ++v)
        domain.extend(background.point(static_cast<std::int32_t>(v)));
    site_reach_ = std::make_unique<core::Adt>(domain, core::AdtItems::boxes);
}

double RetryPolicy::shrink(const Eigen::Vector3d& x) const {
    double scale = 1.0, round_factor = 1.0;
    int generation = -1;
    // The sites that reach x, in increasing index and so in increasing generation; a site
    // that does not reach x gives a factor of 1.
    thread_local std::vector<std::int32_t> reach;
    site_reach_->query_box(core::AdtBox::of_point(x), reach);
    for (const std::int32_t k : reach) {
        const ShrinkSite& site = shrink_sites_[std::size_t(k)];
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
    const double r = radius_in_h * field_.at(centre, -1);
    site_reach_->insert(static_cast<std::int32_t>(shrink_sites_.size()),
                        core::AdtBox::of_point(centre).enlarged(2.0 * r));
    shrink_sites_.push_back({centre, r, generation_});
}

RetryPolicy::RetryPolicy(RetryPolicy&& old, const std::vector<std::int32_t>& old_of_new,
                         const std::vector<std::uint8_t>& is_cut)
    : RetryPolicy(std::move(old)) {
    const std::size_t np = old_of_new.size();
    std::vector<std::uint8_t> rescaled(np, 0), copy(np, 0);
    std::vector<int> stalls(np, 0), crossings(np, 0);
    for (std::size_t q = 0; q < np; ++q) {
        const std::int32_t p = old_of_new[q];
        if (p >= 0) {
            rescaled[q] = rescaled_[std::size_t(p)];
            copy[q] = copy_patch_[std::size_t(p)];
            stalls[q] = patch_stalls_[std::size_t(p)];
            crossings[q] = patch_crossings_[std::size_t(p)];
        } else if (is_cut[q]) {
            copy[q] = 1;
        } else {
            rescaled[q] = 1;  // its loops are new: it is meshed again anyway
            stalls[q] = 1;
        }
    }
    rescaled_ = std::move(rescaled);
    copy_patch_ = std::move(copy);
    patch_stalls_ = std::move(stalls);
    patch_crossings_ = std::move(crossings);
    cuts_.clear();
}

void RetryPolicy::on_stall(std::size_t p, std::size_t patch_faces,
                           const std::vector<Eigen::Vector3d>& places, int round) {
    // In a late round, a finer size has no round left to prove itself: the patch keeps its
    // background triangles at once, so the last round cannot stall there.
    // A cut is made only before that: its rest is meshed in the next round, and a stall of
    // the rest there is still a second stall that is cut or copied, never the error.
    const bool no_retry = late(round) || frugal_;
    // Many places at once (a noisy thresholded head: fins of skin every few cm) are not thin
    // layers that a finer size mends: they are cut at the first stall.
    const bool many = places.size() >= kCutAtOnce;
    if (++patch_stalls_[p] >= 2 || no_retry || (many && patch_faces >= kMinCutFaces)) {
        if (!no_retry && patch_faces >= kMinCutFaces)
            cuts_.push_back({p, places});
        else
            copy_patch_[p] = 1;
        return;
    }
    for (const Eigen::Vector3d& place : places) add_shrink_site(place, 4.0);
}

void RetryPolicy::on_open_edges(const std::vector<Eigen::Vector3d>& midpoints) {
    for (const Eigen::Vector3d& m : midpoints) add_shrink_site(m, 2.0);
}

void RetryPolicy::on_bad_faces(const std::vector<std::int32_t>& faces,
                               const core::SurfaceNetwork& out,
                               const std::vector<std::int32_t>& face_patch, int round) {
    std::set<std::int32_t> bad;
    for (const std::int32_t face : faces) bad.insert(face_patch[std::size_t(face)]);
    // As for stalls: in a late round, finer sizes would be tried in the last
    // round, where a stall they cause is the error; the bad patches are copied instead.
    for (const std::int32_t q : bad)
        if (++patch_crossings_[std::size_t(q)] >= 3 || late(round) || frugal_)
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

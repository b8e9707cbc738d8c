#include "pipeline/core/coordinate_range.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <limits>
#include <sstream>

#include "pipeline/core/error.h"

namespace frontmesh::core {
namespace {

std::string point_text(const double* p) {
    std::ostringstream s;
    s.precision(6);
    s << "(" << p[0] << ", " << p[1] << ", " << p[2] << ") mm";
    return s.str();
}

}  // namespace

void require_coordinates_in_range(const std::vector<double>& xyz, const std::string& source) {
    const std::size_t n = xyz.size() / 3;
    double lo[3], hi[3];
    std::fill(lo, lo + 3, std::numeric_limits<double>::infinity());
    std::fill(hi, hi + 3, -std::numeric_limits<double>::infinity());
    for (std::size_t i = 0; i < n; ++i) {
        const double* p = &xyz[3 * i];
        for (int k = 0; k < 3; ++k) {
            if (!std::isfinite(p[k]))
                FM_THROW(InputError, source + ": point " + std::to_string(i) +
                                         " has a non-finite coordinate " + point_text(p));
            if (std::abs(p[k]) > max_coordinate_mm) {
                std::ostringstream limit;
                limit << max_coordinate_mm;
                FM_THROW(InputError, source + ": point " + std::to_string(i) + " at " +
                                         point_text(p) + " is out of range: coordinates must " +
                                         "be within +-" + limit.str() +
                                         " mm (is the file in another unit, or a point astray?)");
            }
            lo[k] = std::min(lo[k], p[k]);
            hi[k] = std::max(hi[k], p[k]);
        }
    }
    if (n == 0) return;
    const double extent = std::max({hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]});
    if (!(extent >= min_extent_mm)) {
        std::ostringstream s;
        s.precision(3);
        s << extent << " mm across (bounding box from " << point_text(lo) << " to "
          << point_text(hi) << "), less than " << min_extent_mm;
        FM_THROW(InputError, source + ": the geometry is " + s.str() +
                                 " mm: too small to mesh (is the file in another unit, or "
                                 "scaled wrongly?)");
    }
}

}  // namespace frontmesh::core

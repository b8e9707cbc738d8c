#include "pipeline/core/label_image.h"

namespace frontmesh::core {

std::string frame_name(Frame frame) { return frame == Frame::Ras ? "ras" : "lps"; }

}  // namespace frontmesh::core

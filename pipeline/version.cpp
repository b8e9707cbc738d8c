#include "pipeline/version.h"

namespace frontmesh::pipeline {

const char* version() { return FRONTMESH_VERSION; }  // set by pipeline/CMakeLists.txt

}  // namespace frontmesh::pipeline

#pragma once

namespace frontmesh::pipeline {

/// frontmesh's version ("MAJOR.MINOR.PATCH"), from CMake's project(VERSION).
const char* version();

}  // namespace frontmesh::pipeline

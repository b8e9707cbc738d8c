#pragma once
// Robust geometric predicates: a floating-point filter with an exact fallback
// (expansion arithmetic after Shewchuk, DCG 1997). Exact signs for finite input at any absolute
// scale, provided every nonzero coordinate of one call is at least 2^-160 times the largest
// magnitude in that call (2^-300 for orient3d, 2^-480 for orient2d); smaller ones could make a
// product of coordinates underflow.
// Use them for decisions (orientation, intersection); rank candidates with plain doubles.

#include <Eigen/Core>

namespace frontmesh::core {

/// Sign of det[a-d; b-d; c-d]: +1 when d lies below the plane through a, b, c
/// (a, b, c counter-clockwise seen from above, i.e. d on the side opposite the right-hand
/// normal), -1 above, 0 exactly coplanar.
int orient3d(const double* a, const double* b, const double* c, const double* d);

inline int orient3d(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c,
                    const Eigen::Vector3d& d) {
    return orient3d(a.data(), b.data(), c.data(), d.data());
}

/// Sign of the 2-D orientation of (a, b, c) projected on coordinates (i, j) of 3-D points:
/// +1 counter-clockwise, -1 clockwise, 0 collinear.
int orient2d(const double* a, const double* b, const double* c, int i, int j);

/// Sign of the in-sphere test: +1 when e lies inside the sphere through a, b, c, d, where
/// orient3d(a, b, c, d) > 0; -1 outside; 0 on the sphere.
int insphere(const double* a, const double* b, const double* c, const double* d, const double* e);

/// True when a, b, c are collinear (including coincident points): the triangle has zero area.
bool is_degenerate_triangle(const double* a, const double* b, const double* c);

/// True when the closed segment [p, q] and the closed triangle (a, b, c) share a point. Handles
/// coplanar input and degenerate segments and triangles (a point, or collinear vertices).
bool segment_intersects_triangle(const double* p, const double* q, const double* a, const double* b,
                                 const double* c);

/// True when the closed triangles (a0, a1, a2) and (b0, b1, b2) share a point. Degenerate
/// triangles (collinear or coincident vertices) are treated as the segment or point they span.
bool triangles_intersect(const double* a0, const double* a1, const double* a2, const double* b0,
                         const double* b1, const double* b2);

}  // namespace frontmesh::core

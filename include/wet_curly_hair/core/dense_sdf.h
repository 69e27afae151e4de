// A signed distance field sampled on a dense, contiguous, axis-aligned grid, with trilinear
// interpolation of the distance and of its gradient.
#pragma once

#include <cstddef>
#include <vector>

#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// Signed distance field on a dense grid, in the field's own frame (for an OctoMap obstacle
/// field: the map frame; its pose in the world is kept beside it by the caller).
///
/// Sample (i, j, k) sits at the centre of voxel (i, j, k): origin_m + voxel_m * (i, j, k), and is
/// stored at distance_m[i + dims.x() * (j + dims.y() * k)] (x fastest). Values are in metres,
/// negative inside obstacles. The interpolation box is [origin_m, origin_m + voxel_m * (dims - 1)].
///
/// All queries are total: an empty field answers +infinity with gradient +z, a non-finite query
/// point answers NaN with gradient +z; nothing throws or crashes.
struct DenseSdf {
  Vec3 origin_m = Vec3::Zero();                    ///< centre of voxel (0, 0, 0), m, field frame.
  double voxel_m = 0.0;                            ///< voxel edge length h, m.
  Eigen::Vector3i dims = Eigen::Vector3i::Zero();  ///< voxels along x, y, z.
  std::vector<float> distance_m;  ///< signed distance at voxel centres, m, x fastest.

  /// True when the field holds no usable data: a non-positive dimension, a non-positive or
  /// non-finite voxel size, or a sample count different from dims.prod().
  bool empty() const;

  /// True when p (m, field frame) lies inside the interpolation box (boundary included).
  bool contains(const Vec3& p) const;

  /// Trilinearly interpolated signed distance at p (m, field frame), in m.
  /// Outside the interpolation box: the value at the point of the box nearest to p plus the
  /// distance from p to the box. This is the continuous 1-Lipschitz extension of the field that
  /// grows like the distance to the box: space outside the box is treated as ever freer.
  double distance(const Vec3& p) const;

  /// distance(p) and the unit gradient of the same function (dimensionless, field frame).
  /// Inside the box this is the gradient of the trilinear interpolant, normalised. Where it is
  /// not differentiable the choice is fixed: exactly on a sample plane (a voxel centre or a cell
  /// face of the interpolation lattice) the derivative across that plane is the central
  /// difference over the two neighbouring cells (one-sided on the box boundary). Where the raw
  /// gradient vanishes, central differences of distance() over one voxel are used, and where
  /// those vanish too, +z. Outside the box, the gradient of the extension: the field gradient on
  /// the unclamped axes plus the unit vector from the box to p. *unit_gradient always receives a
  /// unit vector (may be null).
  double distanceAndGradient(const Vec3& p, Vec3* unit_gradient) const;

  /// Heap plus object size of the field, in bytes.
  size_t memoryBytes() const;

  /// Index of sample (i, j, k) in distance_m; no bounds check.
  size_t index(int i, int j, int k) const {
    return static_cast<size_t>(i) +
           static_cast<size_t>(dims.x()) *
               (static_cast<size_t>(j) + static_cast<size_t>(dims.y()) * static_cast<size_t>(k));
  }
};

}  // namespace wet_curly_hair

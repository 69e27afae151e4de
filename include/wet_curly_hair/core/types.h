// Basic types of the ROS-free core: 3-vectors, rotations and rigid poses in SI units.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

namespace wet_curly_hair {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;
using Quat = Eigen::Quaterniond;
using Vec3List = std::vector<Vec3, Eigen::aligned_allocator<Vec3>>;
using Mat3List = std::vector<Mat3, Eigen::aligned_allocator<Mat3>>;

/// A rigid transform from one frame to another (e.g. head -> world): x_world = R x_head + t.
struct Pose {
  Quat rotation = Quat::Identity();
  Vec3 translation = Vec3::Zero();

  Vec3 apply(const Vec3& x) const { return rotation * x + translation; }
  Vec3 applyInverse(const Vec3& x) const { return rotation.conjugate() * (x - translation); }
  Vec3 rotate(const Vec3& v) const { return rotation * v; }
  Pose inverse() const {
    Pose p;
    p.rotation = rotation.conjugate();
    p.translation = -(p.rotation * translation);
    return p;
  }
  Pose operator*(const Pose& o) const {
    Pose p;
    p.rotation = rotation * o.rotation;
    p.translation = rotation * o.translation + translation;
    return p;
  }
  bool isFinite() const { return rotation.coeffs().allFinite() && translation.allFinite(); }
};

/// Pose at fraction s in [0, 1] between a and b: linear in translation, slerp in rotation.
/// The roots are moved with this at every substep (docs/physics.md §9.2 step 1).
inline Pose interpolate(const Pose& a, const Pose& b, double s) {
  Pose p;
  p.translation = (1.0 - s) * a.translation + s * b.translation;
  p.rotation = a.rotation.slerp(s, b.rotation).normalized();
  return p;
}

/// Rigid velocity of a frame: linear velocity of its origin and angular velocity, world frame.
struct Twist {
  Vec3 linear = Vec3::Zero();   // m/s
  Vec3 angular = Vec3::Zero();  // rad/s
  /// Velocity of a point at world position x moving rigidly with the frame whose origin is
  /// `origin`.
  Vec3 velocityAt(const Vec3& x, const Vec3& origin) const {
    return linear + angular.cross(x - origin);
  }
};

}  // namespace wet_curly_hair

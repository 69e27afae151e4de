#include "wet_curly_hair/core/dense_sdf.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace wet_curly_hair {
namespace {

/// Below this length a gradient is treated as vanishing (dimensionless).
constexpr double kVanishingGradient = 1e-12;

/// Interpolation weights along one axis: value weights over up to two samples and derivative
/// weights (1/m) over up to three.
struct AxisStencil {
  int n_val = 0;
  int val_index[2] = {0, 0};
  double val_weight[2] = {0.0, 0.0};
  int n_der = 0;
  int der_index[3] = {0, 0, 0};
  double der_weight[3] = {0.0, 0.0, 0.0};
};

/// Stencil at lattice coordinate u (already clamped to [0, n - 1]) on an axis of n samples with
/// spacing h (m). Cell i = floor(u) (the last cell for u = n - 1); exactly on an interior sample
/// plane (t == 0, i > 0) the derivative is the central difference over both neighbouring cells.
AxisStencil axisStencil(double u, int n, double h) {
  AxisStencil s;
  if (n <= 1) {
    s.n_val = 1;
    s.val_index[0] = 0;
    s.val_weight[0] = 1.0;
    return s;  // No extent along this axis: zero derivative.
  }
  int i = static_cast<int>(std::floor(u));
  i = std::min(std::max(i, 0), n - 2);
  const double t = u - i;
  s.n_val = 2;
  s.val_index[0] = i;
  s.val_index[1] = i + 1;
  s.val_weight[0] = 1.0 - t;
  s.val_weight[1] = t;
  if (t == 0.0 && i > 0) {
    s.n_der = 2;
    s.der_index[0] = i - 1;
    s.der_index[1] = i + 1;
    s.der_weight[0] = -0.5 / h;
    s.der_weight[1] = 0.5 / h;
  } else {
    s.n_der = 2;
    s.der_index[0] = i;
    s.der_index[1] = i + 1;
    s.der_weight[0] = -1.0 / h;
    s.der_weight[1] = 1.0 / h;
  }
  return s;
}

}  // namespace

bool DenseSdf::empty() const {
  if (dims.x() <= 0 || dims.y() <= 0 || dims.z() <= 0) return true;
  if (!std::isfinite(voxel_m) || voxel_m <= 0.0 || !origin_m.allFinite()) return true;
  const size_t n =
      static_cast<size_t>(dims.x()) * static_cast<size_t>(dims.y()) * static_cast<size_t>(dims.z());
  return distance_m.size() != n;
}

bool DenseSdf::contains(const Vec3& p) const {
  if (empty()) return false;
  for (int a = 0; a < 3; ++a) {
    const double lo = origin_m[a];
    const double hi = origin_m[a] + voxel_m * (dims[a] - 1);
    if (!(p[a] >= lo && p[a] <= hi)) return false;
  }
  return true;
}

double DenseSdf::distance(const Vec3& p) const {
  if (empty()) return std::numeric_limits<double>::infinity();
  if (!p.allFinite()) return std::numeric_limits<double>::quiet_NaN();
  AxisStencil s[3];
  double outside[3];
  for (int a = 0; a < 3; ++a) {
    const double hi = voxel_m * (dims[a] - 1);
    const double x = p[a] - origin_m[a];
    const double xc = std::min(std::max(x, 0.0), hi);
    outside[a] = x - xc;
    s[a] = axisStencil(xc / voxel_m, dims[a], voxel_m);
  }
  double d = 0.0;
  for (int c = 0; c < s[2].n_val; ++c) {
    for (int b = 0; b < s[1].n_val; ++b) {
      const double wbc = s[1].val_weight[b] * s[2].val_weight[c];
      const size_t row = index(0, s[1].val_index[b], s[2].val_index[c]);
      for (int a = 0; a < s[0].n_val; ++a) {
        d += wbc * s[0].val_weight[a] * distance_m[row + s[0].val_index[a]];
      }
    }
  }
  return d + std::hypot(outside[0], outside[1], outside[2]);  // hypot: no overflow.
}

double DenseSdf::distanceAndGradient(const Vec3& p, Vec3* unit_gradient) const {
  if (empty()) {
    if (unit_gradient) *unit_gradient = Vec3::UnitZ();
    return std::numeric_limits<double>::infinity();
  }
  if (!p.allFinite()) {
    if (unit_gradient) *unit_gradient = Vec3::UnitZ();
    return std::numeric_limits<double>::quiet_NaN();
  }
  AxisStencil s[3];
  Vec3 outside = Vec3::Zero();
  bool clamped[3] = {false, false, false};
  for (int a = 0; a < 3; ++a) {
    const double hi = voxel_m * (dims[a] - 1);
    const double x = p[a] - origin_m[a];
    const double xc = std::min(std::max(x, 0.0), hi);
    outside[a] = x - xc;
    clamped[a] = x != xc;
    s[a] = axisStencil(xc / voxel_m, dims[a], voxel_m);
  }

  // Value and the three partial derivatives of the trilinear interpolant at the clamped point.
  double d = 0.0;
  for (int c = 0; c < s[2].n_val; ++c) {
    for (int b = 0; b < s[1].n_val; ++b) {
      const double wbc = s[1].val_weight[b] * s[2].val_weight[c];
      const size_t row = index(0, s[1].val_index[b], s[2].val_index[c]);
      for (int a = 0; a < s[0].n_val; ++a) {
        d += wbc * s[0].val_weight[a] * distance_m[row + s[0].val_index[a]];
      }
    }
  }
  Vec3 g = Vec3::Zero();
  for (int axis = 0; axis < 3; ++axis) {
    if (clamped[axis]) continue;  // The extension does not vary with the field along this axis.
    // Derivative stencil on `axis`, value stencils on the other two.
    const int ax1 = (axis + 1) % 3;
    const int ax2 = (axis + 2) % 3;
    const AxisStencil& sd = s[axis];
    const AxisStencil& s1 = s[ax1];
    const AxisStencil& s2 = s[ax2];
    double sum = 0.0;
    for (int k = 0; k < sd.n_der; ++k) {
      for (int b = 0; b < s1.n_val; ++b) {
        for (int c = 0; c < s2.n_val; ++c) {
          int ijk[3];
          ijk[axis] = sd.der_index[k];
          ijk[ax1] = s1.val_index[b];
          ijk[ax2] = s2.val_index[c];
          sum += sd.der_weight[k] * s1.val_weight[b] * s2.val_weight[c] *
                 distance_m[index(ijk[0], ijk[1], ijk[2])];
        }
      }
    }
    g[axis] = sum;
  }
  const double outside_norm = std::hypot(outside.x(), outside.y(), outside.z());
  if (outside_norm > 0.0) g += outside / outside_norm;
  d += outside_norm;

  if (unit_gradient) {
    double n = g.norm();
    if (!(n > kVanishingGradient) || !std::isfinite(n)) {
      // Fallback: central differences of the (extended) field over one voxel.
      for (int a = 0; a < 3; ++a) {
        Vec3 e = Vec3::Zero();
        e[a] = voxel_m;
        g[a] = (distance(p + e) - distance(p - e)) / (2.0 * voxel_m);
      }
      n = g.norm();
    }
    *unit_gradient = (n > kVanishingGradient && std::isfinite(n)) ? Vec3(g / n) : Vec3::UnitZ();
  }
  return d;
}

size_t DenseSdf::memoryBytes() const {
  return sizeof(DenseSdf) + distance_m.capacity() * sizeof(float);
}

}  // namespace wet_curly_hair

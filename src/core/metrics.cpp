#include "wet_curly_hair/core/metrics.h"

#include <algorithm>
#include <cmath>

#include "wet_curly_hair/core/cohesion.h"

namespace wet_curly_hair {

double clumpDistance(const HairModel& model, const Vec3List& points,
                     const std::vector<double>& saturation, double radius, NeighborGrid* grid) {
  buildNeighborGrid(points, radius, grid);
  double sum = 0.0;
  long count = 0;
  for (int i = 0; i < model.particleCount(); ++i) {
    if (saturation[i] <= 0.0) continue;
    double best2 = radius * radius;
    forEachOtherStrandNeighbor(*grid, points, grid->strand_of[i], points[i], radius,
                               [&](uint32_t, double r2) { best2 = std::min(best2, r2); });
    sum += std::sqrt(best2);
    ++count;
  }
  return count ? sum / count : 0.0;
}

double segmentDistance(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1) {
  // Closest points of two segments (clamped parameters; Ericson, Real-Time Collision Detection).
  const Vec3 d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  double s = 0.0, t = 0.0;
  if (a <= 1e-24 && e <= 1e-24) return r.norm();
  if (a <= 1e-24) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = d1.dot(r);
    if (e <= 1e-24) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      const double b = d1.dot(d2), denom = a * e - b * b;
      s = denom > 1e-24 ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0.0) {
        t = 0.0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1.0) {
        t = 1.0;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  return ((p0 + s * d1) - (q0 + t * d2)).norm();
}

int tangleCount(const HairModel& model, const Vec3List& points, double strand_radius,
                NeighborGrid* grid) {
  // Segments are found through their root-side particle: two segments can touch only if their
  // root-side particles are within one edge length plus the contact distance of each other.
  double max_edge = 0.0;
  for (int s = 0; s < model.strandCount(); ++s)
    for (int i = model.strandBegin(s); i + 1 < model.strandBegin(s) + model.strandSize(s); ++i)
      max_edge = std::max(max_edge, (points[i + 1] - points[i]).norm());
  const double contact = 2.0 * strand_radius;
  const double search = 2.0 * max_edge + contact;
  buildNeighborGrid(points, search, grid);
  int count = 0;
  for (int s = 0; s < model.strandCount(); ++s) {
    const int end = model.strandBegin(s) + model.strandSize(s);
    for (int i = model.strandBegin(s); i + 1 < end; ++i) {
      forEachOtherStrandNeighbor(*grid, points, s, points[i], search, [&](uint32_t j, double) {
        const int sj = static_cast<int>(grid->strand_of[j]);
        if (sj < s) return;  // each pair once
        if (static_cast<int>(j) + 1 >= model.strandBegin(sj) + model.strandSize(sj)) return;
        if (segmentDistance(points[i], points[i + 1], points[j], points[j + 1]) < contact) ++count;
      });
    }
  }
  return count;
}

CurlShape tipCurlShape(const HairModel& model, const Vec3List& points) {
  CurlShape out;
  int strands = 0;
  for (int s = 0; s < model.strandCount(); ++s) {
    const int begin = model.strandBegin(s), n = model.strandSize(s);
    if (n < 5) continue;
    double kappa_sum = 0.0, tau_sum = 0.0;
    int samples = 0;
    for (int i = begin + (2 * n) / 3; i + 3 < begin + n; ++i) {
      const Vec3 e0 = points[i + 1] - points[i], e1 = points[i + 2] - points[i + 1],
                 e2 = points[i + 3] - points[i + 2];
      const double l = (e0.norm() + e1.norm() + e2.norm()) / 3.0;
      const Vec3 b0 = e0.cross(e1), b1 = e1.cross(e2);
      if (b0.norm() < 1e-15 || b1.norm() < 1e-15 || l <= 0.0) {
        ++samples;  // straight there: zero curvature
        continue;
      }
      const double turn = std::atan2(b0.norm(), e0.dot(e1));  // angle between edges
      const double twist = std::atan2(b0.cross(b1).dot(e1.normalized()), b0.dot(b1));
      kappa_sum += 2.0 * std::sin(0.5 * turn) / l;  // circle through three points: exact
      tau_sum += twist / l;
      ++samples;
    }
    if (samples == 0) continue;
    const double kappa = kappa_sum / samples, tau = tau_sum / samples;
    const double k2 = kappa * kappa + tau * tau;
    if (k2 > 0.0) {
      out.radius_m += kappa / k2;
      out.pitch_m += 2.0 * M_PI * std::abs(tau) / k2;
    }
    ++strands;
  }
  if (strands) {
    out.radius_m /= strands;
    out.pitch_m /= strands;
  }
  return out;
}

}  // namespace wet_curly_hair

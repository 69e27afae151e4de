#include "wet_curly_hair/core/groom.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <sstream>

#include "wet_curly_hair/core/config.h"
#include "wet_curly_hair/core/frames.h"

namespace wet_curly_hair {

bool Groom::validate(std::string* why) const {
  if (strand_offsets.empty() || strand_offsets.front() != 0) {
    if (why) *why = "groom: strand_offsets must start at 0";
    return false;
  }
  if (strandCount() < 1) {
    if (why) *why = "groom: no strands";
    return false;
  }
  if (strand_offsets.back() != points.size()) {
    if (why) *why = "groom: strand_offsets do not end at the point count";
    return false;
  }
  if (root_normals.size() != static_cast<size_t>(strandCount())) {
    if (why) *why = "groom: one root normal per strand is required";
    return false;
  }
  for (int s = 0; s < strandCount(); ++s) {
    if (strand_offsets[s + 1] < strand_offsets[s] + 2) {
      if (why) *why = "groom: strand " + std::to_string(s) + " has fewer than 2 particles";
      return false;
    }
    if (!root_normals[s].allFinite() || root_normals[s].norm() < 0.5) {
      if (why) *why = "groom: root normal of strand " + std::to_string(s) + " is not a unit vector";
      return false;
    }
    for (uint32_t i = strand_offsets[s]; i < strand_offsets[s + 1]; ++i) {
      if (!points[i].allFinite()) {
        if (why) *why = "groom: point " + std::to_string(i) + " is not finite";
        return false;
      }
      if (i + 1 < strand_offsets[s + 1] && (points[i + 1] - points[i]).norm() < 1e-9) {
        if (why) {
          *why = "groom: strand " + std::to_string(s) + " has a zero-length edge at point " +
                 std::to_string(i);
        }
        return false;
      }
    }
  }
  return true;
}

bool GroomConfig::validate(const std::string& p, std::string* why) const {
  using namespace config_check;
  if (strands < 1 || strands > 10000000) {
    if (why) *why = p + "strands: " + std::to_string(strands) + " must be in [1, 10000000]";
    return false;
  }
  if (particles < 2 || particles > 4096) {
    if (why) *why = p + "particles: " + std::to_string(particles) + " must be in [2, 4096]";
    return false;
  }
  if (!finiteInRange(p + "length_m", length_m, 1e-4, 10.0, why) ||
      !finiteInRange(p + "curl_radius_m", curl_radius_m, 0.0, 1.0, why) ||
      !finiteInRange(p + "curl_pitch_m", curl_pitch_m, 0.0, 10.0, why) ||
      !finiteInRange(p + "jitter", jitter, 0.0, 0.5, why) ||
      !finiteInRange(p + "linear_density_kg_per_m", linear_density_kg_per_m, 1e-9, 1e3, why) ||
      !finiteInRange(p + "scalp_half_angle_deg", scalp_half_angle_deg, 0.0, 180.0, why) ||
      !finiteVec(p + "scalp_axis", scalp_axis, why))
    return false;
  if (follow_ratio < 1 || follow_ratio > kMaxFollowRatio) {
    if (why) {
      *why = p + "follow_ratio: " + std::to_string(follow_ratio) +
             " must be a whole number in [1, " + std::to_string(kMaxFollowRatio) +
             "] (1: every strand simulated)";
    }
    return false;
  }
  if (scalp_axis.norm() < 1e-9) {
    if (why) *why = p + "scalp_axis: must not be the zero vector";
    return false;
  }
  if (!oneOf(p + "guides", guides, {"sampled", "first"}, why)) return false;
  if (curl_radius_m > 0.0 && curl_pitch_m <= 0.0) {
    if (why)
      *why = p + "curl_pitch_m: must be > 0 when curl_radius_m > 0 (a flat curl lies on the scalp)";
    return false;
  }
  return true;
}

double helixAngleStepForChord(double r, double pitch, double edge) {
  const double rise = pitch / (2.0 * M_PI);
  auto chord = [&](double dt) {
    const double s = std::sin(0.5 * dt);
    return std::sqrt(4.0 * r * r * s * s + rise * rise * dt * dt);
  };
  if (chord(M_PI) <= edge) return M_PI;
  double lo = 0.0, hi = M_PI;
  // Bisection to the last bit: once an iteration changes neither end, every later one repeats
  // it, so stopping there gives the same step as running all 200.
  for (int it = 0; it < 200; ++it) {
    const double mid = 0.5 * (lo + hi), old_lo = lo, old_hi = hi;
    (chord(mid) < edge ? lo : hi) = mid;
    if (lo == old_lo && hi == old_hi) break;
  }
  return 0.5 * (lo + hi);
}

namespace {

/// Deterministic uniform numbers in [0, 1) from mt19937_64 (independent of the standard
/// library's distribution implementations, so grooms are identical across toolchains).
class Uniform {
 public:
  explicit Uniform(uint64_t seed) : engine_(seed) {}
  double next() { return static_cast<double>(engine_() >> 11) * (1.0 / 9007199254740992.0); }
  double symmetric() { return 2.0 * next() - 1.0; }

 private:
  std::mt19937_64 engine_;
};

/// Point on the ellipsoid surface in direction u from its centre, and the outward normal there.
void ellipsoidPoint(const EllipsoidShape& e, const Vec3& u, Vec3* point, Vec3* normal) {
  const Vec3 q = u.cwiseQuotient(e.radii_m);
  const Vec3 x = u / q.norm();
  *point = e.center_m + x;
  *normal = x.cwiseQuotient(e.radii_m.cwiseProduct(e.radii_m)).normalized();
}

/// The generated strand's curve: a helix about the root normal whose radius ramps in with a
/// smoothstep over the first `ramp` radians, so that the strand leaves the scalp along the normal.
struct HelixCurve {
  Vec3 root, normal, u, w;
  double radius, rise, ramp;  ///< m, m per radian, rad
  Vec3 at(double t) const {
    Vec3 tangent;
    return at(t, &tangent);
  }
  /// The point at t and the curve's derivative there, with one sine and cosine.
  Vec3 at(double t, Vec3* tangent) const {
    const double x = std::min(1.0, t / ramp);
    const double r = radius * x * x * (3.0 - 2.0 * x);
    const double dr = t < ramp ? radius * 6.0 * x * (1.0 - x) / ramp : 0.0;
    const double sin_t = std::sin(t), cos_t = std::cos(t);
    const Vec3 around = (cos_t - 1.0) * u + sin_t * w;
    *tangent = normal * rise + dr * around + r * (cos_t * w - sin_t * u);
    return root + normal * (rise * t) + r * around;
  }
};

/// The parameter in [lo, hi] where the curve is `edge` from prev, given |curve(lo) - prev| < edge
/// <= |curve(hi) - prev|: Newton's method on |curve(t) - prev|^2 - edge^2 from `guess`, kept in
/// the bracket (a step that leaves it, or a slope that is not positive, bisects instead).
/// From the helix's own step it takes 1.4 evaluations per placed particle on average where
/// bisecting to the last bit took about 55: those were half of a 10,000-strand start.
double chordParameter(const HelixCurve& curve, const Vec3& prev, double edge, double lo, double hi,
                      double guess) {
  const double edge2 = edge * edge;
  double t = guess > lo && guess < hi ? guess : 0.5 * (lo + hi);
  for (int it = 0; it < 200; ++it) {
    Vec3 tangent;
    const Vec3 d = curve.at(t, &tangent) - prev;
    const double f = d.squaredNorm() - edge2, slope = 2.0 * d.dot(tangent);
    const double step = f / slope;
    if (slope > 0.0 && std::abs(step) <= 4.0 * std::numeric_limits<double>::epsilon() * t)
      return t - step;  // converged (t > lo >= 0)
    (f < 0.0 ? lo : hi) = t;
    double next = t - step;
    if (!(slope > 0.0) || !(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (next == lo || next == hi) return next;  // the bracket is two neighbouring doubles
    t = next;
  }
  return t;
}

}  // namespace

Groom generateGroom(const GroomConfig& c, const EllipsoidShape& head) {
  Groom g;
  g.strand_offsets.assign(1, 0);
  Uniform rng(static_cast<uint64_t>(c.seed) * 0x9E3779B97F4A7C15ull + 12345u);
  const Vec3 axis = c.scalp_axis.normalized();
  const Mat3 cap_frame = frameFromTangent(axis, Vec3::UnitX());
  const double cos_max = std::cos(c.scalp_half_angle_deg * M_PI / 180.0);
  const double golden = M_PI * (3.0 - std::sqrt(5.0));
  for (int s = 0; s < c.strands; ++s) {
    // Fibonacci spiral over the spherical cap, jittered by a fraction of the spacing.
    const double f = (s + 0.5 + 0.4 * c.jitter * rng.symmetric()) / c.strands;
    const double cos_t = 1.0 - f * (1.0 - cos_max);
    const double sin_t = std::sqrt(std::max(0.0, 1.0 - cos_t * cos_t));
    const double phi = golden * s + 0.3 * c.jitter * rng.symmetric();
    const Vec3 dir = cap_frame * Vec3(cos_t, sin_t * std::cos(phi), sin_t * std::sin(phi));
    Vec3 root, normal;
    ellipsoidPoint(head, dir, &root, &normal);

    const double length = c.length_m * (1.0 + c.jitter * rng.symmetric());
    const double radius = c.curl_radius_m * (1.0 + c.jitter * rng.symmetric());
    const double pitch = c.curl_pitch_m * (1.0 + c.jitter * rng.symmetric());
    const double phase = 2.0 * M_PI * rng.next();
    const double edge = length / (c.particles - 1);
    const Mat3 strand_frame = frameFromTangent(normal, Vec3::UnitZ());
    const Vec3 u = std::cos(phase) * strand_frame.col(1) + std::sin(phase) * strand_frame.col(2);
    const Vec3 w = normal.cross(u);

    g.root_normals.push_back(normal);
    g.points.push_back(root);
    if (c.curl_radius_m <= 0.0) {
      for (int k = 1; k < c.particles; ++k) g.points.push_back(root + normal * (k * edge));
    } else {
      // Helix about the root normal, its radius ramped in over the first quarter turn.
      const HelixCurve curve{root, normal, u, w, radius, pitch / (2.0 * M_PI), 0.5 * M_PI};
      // March along the curve placing particles at equal chord length (uniform edges, §10.3).
      const double dt_guess = helixAngleStepForChord(radius, pitch, edge);
      double t = 0.0;
      Vec3 prev = root;
      for (int k = 1; k < c.particles; ++k) {
        double hi = t + 4.0 * dt_guess + 1e-6;
        while ((curve.at(hi) - prev).norm() < edge) hi += dt_guess + 1e-6;
        t = chordParameter(curve, prev, edge, t, hi, t + dt_guess);
        prev = curve.at(t);
        g.points.push_back(prev);
      }
    }
    g.strand_offsets.push_back(static_cast<uint32_t>(g.points.size()));
  }
  return g;
}

Vec3 nearestEllipsoidPoint(const EllipsoidShape& e, const Vec3& x) {
  const Vec3 y = x - e.center_m, r2 = e.radii_m.cwiseProduct(e.radii_m);
  const Vec3 a = e.radii_m.cwiseProduct(y);
  auto excess = [&](double t) {  // F(t): > 0 below the root, < 0 above it
    return (a.array() / (r2.array() + t)).matrix().squaredNorm() - 1.0;
  };
  auto pointAt = [&](double t) {
    return Vec3(e.center_m + (r2.array() * y.array() / (r2.array() + t)).matrix());
  };
  auto alongRay = [&]() -> Vec3 {
    const double k = y.cwiseQuotient(e.radii_m).norm();
    if (!(k > 0.0)) {  // the centre: leave along the shortest axis
      int axis = 0;
      e.radii_m.minCoeff(&axis);
      return e.center_m + e.radii_m[axis] * Vec3::Unit(axis);
    }
    return e.center_m + y / k;
  };
  const double f0 = excess(0.0);
  if (f0 == 0.0) return x;
  double lo, hi;
  if (f0 > 0.0) {  // outside: F(|a|) <= 0, since r_i^2 + |a| >= |a| >= |a_i| in every term
    lo = 0.0;
    hi = a.norm();
  } else {  // inside: F rises without bound toward -r_min^2 if a has a component there
    hi = 0.0;
    lo = -r2.minCoeff();
    const double near_pole = lo * (1.0 - 1e-12);
    if (!(excess(near_pole) > 0.0)) return alongRay();
  }
  // Bisection to the end of double precision: the interval halves until its midpoint repeats an
  // end (at most about 2100 halvings; some 60 from these brackets).
  for (int k = 0; k < 4096; ++k) {
    const double mid = 0.5 * (lo + hi);
    if (mid <= lo || mid >= hi) break;
    (excess(mid) > 0.0 ? lo : hi) = mid;
  }
  return pointAt(0.5 * (lo + hi));
}

RootsInside rootsInside(const EllipsoidShape& head, const Groom& groom, double tolerance_m) {
  RootsInside inside;
  for (int s = 0; s < groom.strandCount(); ++s) {
    const Vec3& root = groom.points[groom.strand_offsets[s]];
    if ((root - head.center_m).cwiseQuotient(head.radii_m).squaredNorm() >= 1.0) continue;
    const double depth = (nearestEllipsoidPoint(head, root) - root).norm();
    if (!(depth > tolerance_m)) continue;
    ++inside.count;
    inside.deepest_m = std::max(inside.deepest_m, depth);
  }
  return inside;
}

ScalpPlacement placeRootsOnScalp(const EllipsoidShape& head, Groom* groom) {
  ScalpPlacement placed;
  const Vec3 inv_r2 = head.radii_m.cwiseProduct(head.radii_m).cwiseInverse();
  for (int s = 0; s < groom->strandCount(); ++s) {
    const int begin = static_cast<int>(groom->strand_offsets[s]),
              end = begin + groom->strandSize(s);
    const Vec3 root = nearestEllipsoidPoint(head, groom->points[begin]);
    const Vec3 move = root - groom->points[begin];
    for (int i = begin; i < end; ++i) groom->points[i] += move;
    groom->points[begin] = root;  // exactly on the surface, not root + move's round-off
    groom->root_normals[s] = (root - head.center_m).cwiseProduct(inv_r2).normalized();
    const double moved = move.norm();
    if (moved > 1e-9) ++placed.strands_moved;
    placed.largest_move_m = std::max(placed.largest_move_m, moved);
    for (int i = begin + 1; i < end; ++i)
      placed.particles_inside +=
          (groom->points[i] - head.center_m).cwiseQuotient(head.radii_m).squaredNorm() < 1.0;
  }
  return placed;
}

}  // namespace wet_curly_hair

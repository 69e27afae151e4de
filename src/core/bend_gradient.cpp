#include "wet_curly_hair/core/bend_gradient.h"

#include <cmath>

#include "wet_curly_hair/core/frames.h"
#include "wet_curly_hair/core/smoothing.h"

namespace wet_curly_hair {
namespace {

/// Gradients with respect to a and b of phi = tr(M^T R(a, b)), R the rodrigues rotation of
/// minimalRotation: R = I + [v]x + [v]x^2 / (1 + c), v = a x b, c = a . b. With
/// tr(M^T [v]x) = v . mu (mu the axial vector of M - M^T) and [v]x^2 = v v^T - |v|^2 I,
///   phi = tr M + v . mu + (v^T M v - |v|^2 tr M) / (1 + c),
/// so dphi/dv = q = mu + ((M + M^T) v - 2 tr M v) / (1 + c), dphi/dc = -(v^T M v - |v|^2 tr M) /
/// (1 + c)^2, and through v = a x b, c = a . b: dphi/db = q x a + (dphi/dc) a, dphi/da =
/// b x q + (dphi/dc) b.
void rotationGradient(const Vec3& a, const Vec3& b, const Mat3& m, Vec3* ga, Vec3* gb) {
  const Vec3 v = a.cross(b);
  const double s = 1.0 + a.dot(b);
  const double trace = m.trace();
  const Vec3 mu(m(2, 1) - m(1, 2), m(0, 2) - m(2, 0), m(1, 0) - m(0, 1));
  const Vec3 mv = m * v, mtv = m.transpose() * v;
  const Vec3 q = mu + (mv + mtv - 2.0 * trace * v) / s;
  const double dc = -(v.dot(mv) - v.squaredNorm() * trace) / (s * s);
  *gb = q.cross(a) + dc * a;
  *ga = b.cross(q) + dc * b;
}

}  // namespace

double bendEnergyOfStrand(const Vec3* p, int n, double beta, const Mat3& root_frame,
                          const Vec3* local_target, double k_b) {
  if (n < 2) return 0.0;
  Vec3List d(n - 1);
  Mat3List frames(n - 1);
  smoothDifferences(p, n, beta, d.data());
  transportFrames(root_frame, d.data(), n - 1, frames.data());
  double e = 0.0;
  for (int i = 0; i + 1 < n; ++i)
    e += 0.5 * k_b * (p[i + 1] - p[i] - frames[i] * local_target[i]).squaredNorm();
  return e;
}

void addBendFrameGradientForce(const Vec3* p, int n, double beta, const Mat3& root_frame,
                               const Vec3* local_target, double k_b, Mat3* frames, Vec3* d,
                               Vec3* adjoint, Vec3* force) {
  const int edges = n - 1;
  if (edges < 2 || k_b == 0.0) return;
  // 1. Forward: smoothed differences (eq. 2) and frames.
  smoothDifferences(p, n, beta, d);
  transportFrames(root_frame, d, edges, frames);
  // 2. Backward through the frames: A_i = dE/dF_i (direct, -k r_i t_i^T, plus R_{i+1}^T A_{i+1}
  // from the frames after it); dE/dR_i = A_i F_{i-1}^T goes to the tangents R_i turns between,
  // F_{i-1}'s (= u_{i-1}, column 0 of F_{i-1}) and u_i = d_{i-1} / |d_{i-1}|.
  for (int i = 0; i < edges; ++i) adjoint[i].setZero();
  Mat3 a_next = Mat3::Zero(), r_next = Mat3::Identity();
  for (int i = edges - 1; i >= 0; --i) {
    const Vec3 r = p[i + 1] - p[i] - frames[i] * local_target[i];
    const Mat3 a = -k_b * r * local_target[i].transpose() + r_next.transpose() * a_next;
    if (i == 0) break;  // the root frame is the head's: nothing flows further
    const double len = d[i - 1].norm();
    if (len < kDirectionEpsilon) {  // transportFrame kept the frame: F_i = F_{i-1}
      a_next = a, r_next = Mat3::Identity();
      continue;
    }
    const Vec3 u = d[i - 1] / len;
    const Vec3 before = frames[i - 1].col(0);
    Vec3 g_before, g_u;
    rotationGradient(before, u, a * frames[i - 1].transpose(), &g_before, &g_u);
    adjoint[i - 1] += (g_u - u.dot(g_u) * u) / len;
    // F_{i-1}'s tangent is u_{i-1} for i >= 2 (the root's tangent is the head's, constant).
    if (i >= 2) {
      const double len_before = d[i - 2].norm();
      if (len_before >= kDirectionEpsilon) {
        const Vec3 w = d[i - 2] / len_before;
        adjoint[i - 2] += (g_before - w.dot(g_before) * w) / len_before;
      }
    }
    a_next = a;
    r_next = minimalRotation(before, u);
  }
  // 3. Backward through eq. (2) to the edges (smoothDifferencesAdjoint), then to the particles.
  smoothDifferencesAdjoint(adjoint, n, beta, d);  // d is free again: the edge gradients
  for (int i = 0; i < edges; ++i) {
    force[i + 1] -= d[i];
    force[i] += d[i];
  }
}

}  // namespace wet_curly_hair

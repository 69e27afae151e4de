// The IIR smoothing filter of Iben et al. 2013, eq. (2) of Kim 2023 (docs/physics.md §2.3, A2, A3).
#pragma once

#include <algorithm>
#include <cmath>

#include "wet_curly_hair/core/lane_math.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// beta = min(1, 1 - exp(-l / alpha)), with l the mean REST edge length of the strand (A3) and
/// alpha the smoothing length (m). alpha <= 0 means no smoothing (beta = 1, d_i = e_i).
WCH_INLINE double smoothingBeta(double mean_rest_edge_m, double alpha_m) {
  if (!(alpha_m > 0.0)) return 1.0;
  return std::min(1.0, 1.0 - std::exp(-mean_rest_edge_m / alpha_m));
}

/// Eq. (2): d_i = 2(1-beta) d_{i-1} - (1-beta)^2 d_{i-2} + beta^2 (lambda_{i+1} - lambda_i),
/// started with d_{-1} = d_{-2} = lambda_1 - lambda_0 (A2), so that d_0 = lambda_1 - lambda_0.
/// Input: `count` samples lambda (positions or velocities); output: count - 1 differences d.
/// A critically damped second-order low pass with unit DC gain: a straight uniform strand is
/// reproduced exactly. Causal root -> tip: d_i depends on lambda_0 .. lambda_{i+1} only.
/// Generic over the sample and scalar types: Vec3 with double here, and the strand-lane types
/// (a block of strands, each lane with its own beta) in strand_block.h.
template <typename Sample, typename Scalar>
WCH_INLINE void smoothDifferences(const Sample* lambda, int count, Scalar beta, Sample* d) {
  if (count < 2) return;
  const Scalar f1 = 2.0 * (1.0 - beta);
  const Scalar f2 = (1.0 - beta) * (1.0 - beta);
  const Scalar f3 = beta * beta;
  Sample dm1 = lambda[1] - lambda[0];
  Sample dm2 = dm1;
  for (int i = 0; i + 1 < count; ++i) {
    const Sample di = f1 * dm1 - f2 * dm2 + f3 * (lambda[i + 1] - lambda[i]);
    d[i] = di;
    dm2 = dm1;
    dm1 = di;
  }
}

/// The transpose of smoothDifferences: given g_i = dE/dd_i for the count - 1 differences, writes
/// dE/de_i for the count - 1 edges e_i = lambda_{i+1} - lambda_i (reverse mode through eq. 2):
/// a_i = g_i + f1 a_{i+1} - f2 a_{i+2} tip -> root, dE/de_i = f3 a_i, and edge 0 also carries the
/// start d_{-1} = d_{-2} = e_0 (A2). A force computed on d_i and applied to edge i alone (the core
/// spring of eq. 5) is the gradient of its energy only after this.
template <typename Sample, typename Scalar>
WCH_INLINE void smoothDifferencesAdjoint(const Sample* g, int count, Scalar beta, Sample* dedge) {
  if (count < 2) return;
  const Scalar f1 = 2.0 * (1.0 - beta);
  const Scalar f2 = (1.0 - beta) * (1.0 - beta);
  const Scalar f3 = beta * beta;
  Sample a1 = g[0] - g[0], a2 = a1;  // a_{i+1}, a_{i+2}
  for (int i = count - 2; i >= 0; --i) {
    const Sample a = g[i] + f1 * a1 - f2 * a2;
    dedge[i] = f3 * a;
    if (i == 0) dedge[0] = dedge[0] + (f1 - f2) * a - f2 * a1;
    a2 = a1;
    a1 = a;
  }
}

/// Eq. (3): the smoothed curve p'_0 = lambda_0, p'_i = p'_{i-1} + d_{i-1}.
WCH_INLINE void rebuildCurve(const Vec3& root, const Vec3* d, int count, Vec3* curve) {
  if (count < 1) return;
  curve[0] = root;
  for (int i = 1; i < count; ++i) curve[i] = curve[i - 1] + d[i - 1];
}

}  // namespace wet_curly_hair

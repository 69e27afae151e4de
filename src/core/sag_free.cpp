#include "wet_curly_hair/core/sag_free.h"

#include <algorithm>
#include <cmath>

#include "wet_curly_hair/core/frames.h"
#include "wet_curly_hair/core/smoothing.h"

namespace wet_curly_hair {

// The statics of a chain with a kinematic root are known in closed form. With the segment
// convention of the solver (F_i += f_i, F_{i+1} -= f_i), particle j feels
//   F_j = m_j g + f_j - f_{j-1}   (f_{n-1} = 0: the tip has no outgoing edge),
// so F_j = 0 for every non-root j holds exactly when, from the tip down,
//   f_i = g * sum_{j > i} m_j =: W_i,
// the weight hanging below edge i (tension for an edge pointing down: f_i along e_i pulls the
// root-side particle toward the tip). No iteration is needed: the elastic forces of the solver,
//   f_i = k_s (|e_i| - L_i) e^_i + k_b (e_i - F_i t^loc_i) + k_c (|b_i| - c_i) b^_i,
// are evaluated at the groom, where e_i, the smoothed differences b_i and the frames F_i
// (transported along the alpha_b-smoothed groom from the root frame) are all fixed; only the
// rest parameters L_i, t^loc_i, c_i are free, and f_i is affine in each.
//
// Which rest parameters (docs/physics.md §8, "solve rest parameters, not positions"; its Iben
// analogue of Hsu et al.'s local step): the part of W_i ALONG the edge goes to the stretch spring,
// the only spring whose force follows the edge under any deformation, as a real hanging hair
// carries its weight (L_i := |e_i| - (W_i . e^_i) / k_s, §8's first bullet); the part ACROSS the
// edge goes to the bending target, the only spring that acts across it (t^loc_i := F_i^T (e_i -
// W_perp / k_b), §8's second bullet, solved at once since f is linear in the target). The core
// springs keep their groom rest lengths (zero force at the groom): they act along the smoothed
// b_i, not along or across e_i, and they are what holds the curl's radius, so they keep holding
// the groom's. The result is exact to round-off for any groom (curly, straight, imported),
// since F_i F_i^T = I. The stretch preload is capped at kSagFreeMaxPreloadOfStrainLimit of the
// strain limit (the limiter measures strain against L_i); any excess axial load goes to the
// bending target as well, which keeps the balance exact.
//
// Head contacts at the rest pose are ignored (not solved for): the strand carries its whole
// weight, which is also an equilibrium when hair lies on the scalp (the collision projection is
// inactive outside the offset and then sees zero pressing force).
void makeSagFree(const SolverConfig& config, const Vec3& g, HairModel* model, SagFreeStats* stats) {
  SagFreeStats local;
  HairModel& m = *model;
  const double cap = kSagFreeMaxPreloadOfStrainLimit * config.stretch.strain_limit;
  Vec3List d;
  Mat3List frames;
  for (int s = 0; s < m.strandCount(); ++s) {
    const int begin = m.strandBegin(s);
    const int n = m.strandSize(s);
    if (n < 2) continue;
    const Vec3* p = &m.rest_position_head[begin];
    // The frames exactly as the solver computes them at the rest pose on the start head pose.
    d.resize(n - 1);
    frames.resize(n - 1);
    smoothDifferences(p, n, m.beta_bend[s], d.data());
    transportFrames(m.root_frame_head[s], d.data(), n - 1, frames.data());
    const double kb = m.bend_k[s];
    Vec3 weight = Vec3::Zero();  // W_i, summed tip -> root
    for (int i = n - 2; i >= 0; --i) {
      const double ks = m.stretch_k[begin + i];
      weight += m.mass_kg[begin + i + 1] * g;
      const Vec3 e = p[i + 1] - p[i];
      const double len = e.norm();
      Vec3 rest_of_bend = weight;  // what the bending spring must carry
      double rest_length = len;
      if (len > kDirectionEpsilon && ks > 0.0) {
        const Vec3 u = e / len;
        // Tension (> 0) or compression the stretch spring takes, within the preload cap.
        const double axial = weight.dot(u);
        const double lo = len / (1.0 + cap), hi = len / std::max(1e-3, 1.0 - cap);
        rest_length = std::clamp(len - axial / ks, lo, hi);
        const double carried = ks * (len - rest_length);
        if (std::abs(carried - axial) > 1e-12 * std::max(1.0, std::abs(axial)))
          ++local.capped_edges;
        rest_of_bend -= carried * u;
        local.max_preload_strain =
            std::max(local.max_preload_strain, std::abs(len / rest_length - 1.0));
      }
      if (kb > 0.0) {  // k_b = 0 with gravity is refused by SolverConfig::validate
        Vec3& t_loc = m.bend_local_target[begin + i];
        // F^T (e - W / k_b), written as the stored F^T e plus the shift, so that a strand that
        // carries nothing keeps its targets to the bit.
        const Vec3 shifted = t_loc - frames[i].transpose() * (rest_of_bend / kb);
        local.max_bend_shift_m = std::max(local.max_bend_shift_m, (shifted - t_loc).norm());
        t_loc = shifted;
      }
      m.rest_edge_m[begin + i] = rest_length;
      ++local.edges;
    }
  }
  relayModelLanes(model);
  if (stats) *stats = local;
}

}  // namespace wet_curly_hair

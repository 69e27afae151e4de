#include "wet_curly_hair/core/diagnostics.h"

#include <algorithm>
#include <cmath>

#include "wet_curly_hair/core/frames.h"
#include "wet_curly_hair/core/hair_contact.h"
#include "wet_curly_hair/core/smoothing.h"
#include "wet_curly_hair/core/springs.h"

namespace wet_curly_hair {

StrainStats edgeStrain(const HairModel& model, const HairState& state) {
  StrainStats out;
  double sum = 0.0;
  long count = 0;
  for (int s = 0; s < model.strandCount(); ++s) {
    const int begin = model.strandBegin(s);
    for (int i = begin; i + 1 < begin + model.strandSize(s); ++i) {
      const double strain =
          (state.position[i + 1] - state.position[i]).norm() / model.rest_edge_m[i] - 1.0;
      out.max = std::max(out.max, strain);
      sum += std::abs(strain);
      ++count;
    }
  }
  out.mean = count ? sum / count : 0.0;
  return out;
}

double maxHeadPenetration(const HairModel& model, const HairState& state, const Pose& head_pose) {
  double worst = 0.0;
  for (int s = 0; s < model.strandCount(); ++s) {
    const int begin = model.strandBegin(s);
    for (int i = begin + 1; i < begin + model.strandSize(s); ++i) {
      Vec3 n;
      const double d = model.head.distance(head_pose.applyInverse(state.position[i]), &n);
      worst = std::max(worst, -d);
    }
  }
  return worst;
}

EnergyParts energy(const HairModel& model, const SolverConfig& config, const Pose& head_pose,
                   HairState* state, int split, EnergyParts* first_strands) {
  EnergyParts e;
  StrandScratch& scr = state->scratch.front();
  for (int s = 0; s < model.strandCount(); ++s) {
    if (s == split && first_strands) *first_strands = e;
    const int begin = model.strandBegin(s);
    const int n = model.strandSize(s);
    const Vec3* p = &state->position[begin];
    for (int i = 1; i < n; ++i) {
      const double m = model.mass_kg[begin + i];
      e.kinetic += 0.5 * m * state->velocity[begin + i].squaredNorm();
      e.gravity -= m * config.gravity_m_s2.dot(p[i]);
    }
    const Mat3 root_frame = head_pose.rotation.toRotationMatrix() * model.root_frame_head[s];
    smoothDifferences(p, n, model.beta_bend[s], scr.smooth_bend.data());
    transportFrames(root_frame, scr.smooth_bend.data(), n - 1, scr.frame.data());
    smoothDifferences(p, n, model.beta_core[s], scr.smooth_core.data());
    for (int i = 0; i + 1 < n; ++i) {
      const Vec3 edge = p[i + 1] - p[i];
      e.stretch += stretchEnergy(edge, model.rest_edge_m[begin + i], model.stretch_k[begin + i]);
      e.bend +=
          bendEnergy(edge, scr.frame[i] * model.bend_local_target[begin + i], model.bend_k[s]);
      e.core += coreEnergy(scr.smooth_core[i], model.core_rest_m[begin + i], model.core_k[s]);
    }
  }
  if (first_strands && (split < 0 || split >= model.strandCount())) *first_strands = e;
  if (config.hair_contact.enabled)
    e.hair_contact = hairContactEnergy(model, config.hair_contact, state);
  return e;
}

double maxSpeed(const HairModel& model, const HairState& state) {
  double best = 0.0;
  for (int s = 0; s < model.strandCount(); ++s) {
    const int begin = model.strandBegin(s);
    for (int i = begin + 1; i < begin + model.strandSize(s); ++i)
      best = std::max(best, state.velocity[i].norm());
  }
  return best;
}

}  // namespace wet_curly_hair

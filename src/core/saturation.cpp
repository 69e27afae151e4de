#include "wet_curly_hair/core/saturation.h"

#include <algorithm>
#include <cmath>

#include "wet_curly_hair/core/config.h"

namespace wet_curly_hair {

bool validateSaturationCommand(const SaturationCommand& c, const HairModel& model,
                               std::string* why) {
  using namespace config_check;
  const double lo = c.add ? -1.0 : 0.0;
  if (!finiteInRange("root_value", c.root_value, lo, 1.0, why) ||
      !finiteInRange("tip_value", c.tip_value, lo, 1.0, why))
    return false;
  for (size_t k = 0; k < c.strands.size(); ++k) {
    if (c.strands[k] >= static_cast<uint32_t>(model.strandCount())) {
      if (why) {
        *why = "strands[" + std::to_string(k) + "]: strand id " + std::to_string(c.strands[k]) +
               " does not exist (the groom has " + std::to_string(model.strandCount()) + ")";
      }
      return false;
    }
  }
  const SaturationRegion& r = c.region;
  if (r.kind == SaturationRegion::Kind::kSphere) {
    return finiteVec("region.center_m", r.center_m, why) &&
           positive("region.radius_m", r.radius_m, why);
  }
  if (r.kind == SaturationRegion::Kind::kBox) {
    return finiteVec("region.center_m", r.center_m, why) &&
           positive("region.half_extents_m.x", r.half_extents_m.x(), why) &&
           positive("region.half_extents_m.y", r.half_extents_m.y(), why) &&
           positive("region.half_extents_m.z", r.half_extents_m.z(), why);
  }
  return true;
}

int applySaturation(const HairModel& model, const SaturationCommand& c, const Pose& head_pose,
                    HairState* state) {
  const SaturationRegion& r = c.region;
  auto inRegion = [&](const Vec3& x_world) {
    if (r.kind == SaturationRegion::Kind::kEverywhere) return true;
    const Vec3 x = r.in_head_frame ? head_pose.applyInverse(x_world) : x_world;
    if (r.kind == SaturationRegion::Kind::kSphere) return (x - r.center_m).norm() <= r.radius_m;
    return ((x - r.center_m).cwiseAbs() - r.half_extents_m).maxCoeff() <= 0.0;
  };
  auto applyStrand = [&](int s) {
    int changed = 0;
    const int begin = model.strandBegin(s);
    const int n = model.strandSize(s);
    const double length = model.strand_length_m[s];
    double arc = 0.0;
    for (int i = 0; i < n; ++i) {
      if (i > 0) arc += model.rest_edge_m[begin + i - 1];
      if (!inRegion(state->position[begin + i])) continue;
      const double u = length > 0.0 ? arc / length : 0.0;
      const double value = c.root_value + (c.tip_value - c.root_value) * u;
      double& sat = state->saturation[begin + i];
      sat = std::clamp(c.add ? sat + value : value, 0.0, 1.0);
      ++changed;
    }
    return changed;
  };
  int changed = 0;
  if (c.strands.empty()) {
    for (int s = 0; s < model.strandCount(); ++s) changed += applyStrand(s);
  } else {
    for (uint32_t s : c.strands) changed += applyStrand(static_cast<int>(s));
  }
  return changed;
}

}  // namespace wet_curly_hair

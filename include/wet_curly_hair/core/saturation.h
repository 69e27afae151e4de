// Saturation: a per-particle field in [0, 1] (docs/physics.md A18: authored, not simulated), set or
// added by strand list, by region (sphere or box, in the world or head frame), uniform or as a
// root-to-tip ramp, and clamped to [0, 1].
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/state.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// Where a saturation command applies, besides its strand list.
struct SaturationRegion {
  enum class Kind { kEverywhere, kSphere, kBox };
  Kind kind = Kind::kEverywhere;
  bool in_head_frame = false;  ///< false: world frame.
  Vec3 center_m = Vec3::Zero();
  double radius_m = 0.0;               ///< sphere.
  Vec3 half_extents_m = Vec3::Zero();  ///< axis-aligned box (in its frame).
};

struct SaturationCommand {
  std::vector<uint32_t> strands;  ///< strand ids; empty: every strand.
  double root_value = 1.0;        ///< value at the root, linearly ramped by arc length to:
  double tip_value = 1.0;         ///< the value at the tip (equal for a uniform field).
  bool add = false;               ///< false: set; true: add to the current value.
  SaturationRegion region;
};

/// Checks a command against the model: strand ids in range, finite values (within [0, 1] when
/// setting, [-1, 1] when adding), a region of positive size. Names the offending field.
bool validateSaturationCommand(const SaturationCommand& command, const HairModel& model,
                               std::string* why);

/// Applies a valid command. Particles in the region (tested at their current position) of the
/// selected strands get root + (tip - root) * s, with s the rest arc-length fraction of the
/// particle along its strand; set or add, then clamped to [0, 1]. Returns the number of
/// particles changed.
int applySaturation(const HairModel& model, const SaturationCommand& command, const Pose& head_pose,
                    HairState* state);

}  // namespace wet_curly_hair

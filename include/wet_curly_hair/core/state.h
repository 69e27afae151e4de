// HairState: the mutable, preallocated state of the simulation (design.md "The core").
#pragma once

#include <cstdint>
#include <vector>

#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// Numerical trouble detected and repaired, never hidden (style.md §11).
struct WarningStats {
  uint64_t nonfinite_repairs = 0;  ///< strands restored because a value went NaN/Inf.
  uint64_t strain_repairs = 0;     ///< strands restored because strain ran past the bound.
  uint64_t nonfinite_values = 0;   ///< non-finite scalars found before those repairs.
  uint64_t total() const { return nonfinite_repairs + strain_repairs; }
};

/// Scratch space for one strand, sized once for the longest strand.
struct StrandScratch {
  Vec3List force;       ///< per particle, N.
  Vec3List smooth_bend; ///< d of eq. (2) for alpha_b, per edge.
  Vec3List smooth_core; ///< b of eq. (5), per edge.
  Vec3List smooth_vel;  ///< nu of eq. (5), per edge.
  Mat3List frame;       ///< per edge.
  Vec3List target;      ///< t_i per edge.
  void resize(int max_strand_size);
};

/// Mutable state. Allocated by makeState; step() never allocates.
struct HairState {
  Vec3List position;       ///< world frame, m.
  Vec3List velocity;       ///< world frame, m/s.
  std::vector<double> saturation;  ///< per particle, [0, 1].
  Vec3List last_good_position;     ///< per particle, at the end of the last healthy step.
  Vec3List last_good_velocity;
  double time_s = 0.0;             ///< simulated time of the current positions, s.
  uint64_t step_count = 0;
  uint64_t substep_count = 0;
  WarningStats warnings;
  StrandScratch scratch;
};

/// Allocates the state for a model and places the hair in its rest pose, carried by `head_pose`
/// and moving rigidly with the head (`head_twist`, world frame, about the head origin).
HairState makeState(const HairModel& model, const Pose& head_pose, const Twist& head_twist);

/// Puts an existing state back into the rest pose (no allocation).
void resetState(const HairModel& model, const Pose& head_pose, const Twist& head_twist,
                HairState* state);

}  // namespace wet_curly_hair

// Where the cohesion display pass writes its result, shared by the lattice and exact evaluations
// and the followers' interpolation from their guides. Private to the core library.
#pragma once

#include "wet_curly_hair/core/config.h"
#include "wet_curly_hair/core/state.h"

namespace wet_curly_hair {
namespace detail {

/// Particle i's display position p^w = p + offset of eq. (10) (a zero offset: p^w = p, dry or
/// isolated particles), and, where the offsets are held between evaluations
/// (cohesion.refresh_period_s > 0, updateDisplayCohesion), the offset itself, written in the same
/// pass: a separate pass forming p^w - p over every particle afterwards cost as much as a copy of
/// the positions.
struct DisplayWrite {
  Vec3* wet_position;
  Vec3* held_offset;  ///< null: the offsets are not held
  void operator()(int i, const Vec3& p, const Vec3& offset) const {
    wet_position[i] = p + offset;
    if (held_offset) held_offset[i] = offset;
  }
  void unmoved(int i, const Vec3& p) const {
    wet_position[i] = p;
    if (held_offset) held_offset[i] = Vec3::Zero();
  }
};

inline DisplayWrite displayWrite(const CohesionConfig& c, HairState* state) {
  return {state->wet_position.data(),
          c.refresh_period_s > 0.0 ? state->display_offset.data() : nullptr};
}

}  // namespace detail
}  // namespace wet_curly_hair

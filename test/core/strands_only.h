// Test helper shared by the measurement tests: a model that knows only its strands.
#pragma once

#include <vector>

#include "wet_curly_hair/core/model.h"

namespace wet_curly_hair {

/// A model that only knows its strands (the measurements read nothing else of it): strand k has
/// sizes[k] particles, all at the origin until the test places them.
inline HairModel strandsOnly(const std::vector<int>& sizes) {
  HairModel m;
  m.strand_offsets = {0};
  for (int n : sizes) m.strand_offsets.push_back(m.strand_offsets.back() + n);
  m.rest_position_head.assign(m.strand_offsets.back(), Vec3::Zero());
  return m;
}

}  // namespace wet_curly_hair

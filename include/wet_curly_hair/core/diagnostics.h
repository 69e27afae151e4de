// Measurements of a state: strain, penetration, energy. Used by the runner, the tests and the node.
#pragma once

#include "wet_curly_hair/core/config.h"
#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/state.h"

namespace wet_curly_hair {

struct StrainStats {
  double max = 0.0;   ///< largest (L - L0) / L0 over all edges.
  double mean = 0.0;  ///< mean absolute strain over all edges.
};
StrainStats edgeStrain(const HairModel& model, const HairState& state);

/// Deepest penetration of a non-root particle into the head's surface (m, >= 0).
double maxHeadPenetration(const HairModel& model, const HairState& state, const Pose& head_pose);

/// Energy parts (J). Bending and core energies are evaluated with the frames of the current
/// smoothed curve held fixed (the bending force is not an energy gradient, docs/physics.md §2.6).
struct EnergyParts {
  double kinetic = 0.0;
  double gravity = 0.0;  ///< -m g . x, relative to the world origin.
  double stretch = 0.0;
  double bend = 0.0;
  double core = 0.0;
  double hair_contact = 0.0;  ///< the hair contact's penalty (hairContactEnergy), when enabled.
  double total() const { return kinetic + gravity + stretch + bend + core + hair_contact; }
};
/// Absolute kinetic energy (world frame). Uses state->scratch (no allocation). Over every
/// strand; with `first_strands`, also the parts of the first `split` strands alone (every strand
/// when split is negative or past the count), taken on the way in the same pass: with followers
/// the guides come first, so split = model.simulatedStrandCount() gives the energy of what the
/// dynamics advances. The hair contact's penalty couples strands and is counted in the total only.
EnergyParts energy(const HairModel& model, const SolverConfig& config, const Pose& head_pose,
                   HairState* state, int split = -1, EnergyParts* first_strands = nullptr);

/// Largest particle speed (m/s), non-root particles.
double maxSpeed(const HairModel& model, const HairState& state);

}  // namespace wet_curly_hair

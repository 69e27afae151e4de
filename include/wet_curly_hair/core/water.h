// Water that moves: water mass held per particle, taken from showers and baths, wicked along each
// strand, run toward the tips under gravity, shared between strands in contact, dripped where a
// particle holds more than its capacity and evaporated (faster inside a dryer), with every
// kilogram accounted for (docs/water.md). The saturation the wet model reads (curl, cohesion,
// adhesion, eq. 13) is held / capacity, clamped to [0, 1], written after every water step.
#pragma once

#include <cmath>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/state.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// Material of the water model, per length of strand (docs/water.md "Defaults").
struct WaterConfig {
  /// Run the water stage even without a source or dryer (evaporation and transport of the
  /// initial water). Off by default: the saturation is then only what a command sets.
  bool enabled = false;
  /// Water a metre of strand holds at saturation 1, kg/m (about the dry hair's own mass: the
  /// fibres swell by about a third of it and the gaps between them hold the rest).
  double capacity_kg_per_m = 0.012;
  /// D, wicking along a strand: the saturation diffuses as ds/dt = D d^2s/dx^2 on the rest arc
  /// length, m^2/s.
  double wicking_m2_s = 2.0e-4;
  /// Speed at which water runs down a strand hanging along gravity (scaled by the cosine of the
  /// edge's angle to gravity and by |g| / 9.81), m/s; the flux is this times the held water per
  /// length.
  double gravity_flow_m_s = 0.01;
  /// Evaporation rate outside dryers: held water decays as exp(-rate t), 1/s.
  double evaporation_per_s = 3.0e-4;
  /// Exchange between strands in contact: particles sharing a cell of exchange_cell_m (world
  /// frame) with a particle of another strand relax toward the cell's saturation at this rate,
  /// 1/s (0: off).
  double exchange_per_s = 1.0;
  double exchange_cell_m = 0.005;  ///< cell size of the exchange, about a contact distance, m.
  /// The exchange runs once this much simulated time has passed since it last ran, over that
  /// time (its relaxation is exact over any step), s: its time constant, 1 / exchange_per_s, is
  /// 1 s by default, far longer, and it is two thirds of the stage's cost (docs/water.md "Cost").
  /// 0: every step.
  double exchange_interval_s = 0.05;
  /// The held water adds to the particles' masses (gravity and inertia; applyWaterMass): wet
  /// hair is heavier (docs/water.md "Wet hair is heavier" measures by how much it matters).
  bool adds_mass = true;
  bool validate(const std::string& prefix, std::string* why) const;
};

/// Where water comes from, in the world frame, on during [start_s, stop_s).
struct WaterSource {
  enum class Kind { kShower, kBath };
  Kind kind = Kind::kShower;
  /// Shower: the head's centre; it wets the vertical column of radius radius_m below it.
  Vec3 center_m = Vec3::Zero();
  double radius_m = 0.1;
  /// Shower: water reaching the hair in the column, kg/s, shared by length among the particles
  /// in the column (water that finds no hair is not counted).
  double rate_kg_s = 0.01;
  /// Bath: particles below this height (world z) are filled to their capacity, m.
  double level_m = 0.0;
  double start_s = 0.0;
  double stop_s = std::numeric_limits<double>::infinity();
  bool validate(const std::string& prefix, std::string* why) const;
  /// Parses "shower:x=..,y=..,z=..,r=..,rate_kg_s=..,start_s=..,stop_s=.." or
  /// "bath:z=..,start_s=..,stop_s=.."; names the bad field.
  static bool parse(const std::string& spec, WaterSource* out, std::string* why);
  std::string spec() const;  ///< what parse reads back.
};

/// A dryer: an axis-aligned box (world frame) inside which held water evaporates faster.
struct WaterDryer {
  Vec3 center_m = Vec3::Zero();
  Vec3 half_extents_m = Vec3(0.1, 0.1, 0.1);
  /// Evaporation rate added inside the box, 1/s (the default dries in minutes: e-folding time
  /// 100 s).
  double rate_per_s = 0.01;
  double start_s = 0.0;
  double stop_s = std::numeric_limits<double>::infinity();
  bool validate(const std::string& prefix, std::string* why) const;
  /// Parses "box:x=..,y=..,z=..,hx=..,hy=..,hz=..,rate_per_s=..,start_s=..,stop_s=..".
  static bool parse(const std::string& spec, WaterDryer* out, std::string* why);
  std::string spec() const;
};

/// The sources and dryers a water step sees.
struct WaterSources {
  std::vector<WaterSource> sources;
  std::vector<WaterDryer> dryers;
  bool empty() const { return sources.empty() && dryers.empty(); }
};

/// What one water step did (kg over the step).
struct WaterStepStats {
  double added_kg = 0.0;
  double dripped_kg = 0.0;
  double evaporated_kg = 0.0;
  uint64_t drips = 0;               ///< particles that dripped.
  uint64_t exchange_particles = 0;  ///< particles in a cell with another strand's.
  uint64_t shower_particles = 0;    ///< particles a shower wet.
};

// Kernels: stateless, on one strand or one particle (tested against analytic answers).

/// Water a particle holds at saturation 1, kg.
inline double particleCapacity(const HairModel& model, const WaterConfig& config, int i) {
  return config.capacity_kg_per_m * model.length_share_m[i];
}

/// One backward-Euler step of wicking and gravity flow on a strand of n particles: solves
/// (C + dt A) u' = C u for the water per capacity u = held / capacity, with C the particle
/// capacities and A the flux operator: diffusion D c (u_{i+1} - u_i) / L_i across edge i
/// (c = capacity per length) and upwind gravity flow v max(0, a_i) c u_i down the edge (a_i the
/// cosine of edge i's direction with gravity, signed). Every column of (C + dt A) sums to its
/// capacity, so the water is conserved to round-off; the matrix is an M-matrix, so the water
/// stays non-negative; backward Euler is stable at any step (a frame may be longer than the
/// explicit bound L^2 / 2D). `held` is updated in place; `scratch` holds 2 n doubles.
void transportStrand(int n, const double* capacity, const double* edge_m, const double* downhill,
                     double capacity_per_m, double wicking_m2_s, double flow_m_s, double dt,
                     double* held, double* scratch);

/// Evaporation over dt at `rate_per_s`: the held water decays exactly as exp(-rate dt). Returns
/// the evaporated mass.
inline double evaporate(double rate_per_s, double dt, double* held) {
  const double gone = *held * -std::expm1(-rate_per_s * dt);
  *held -= gone;
  return gone;
}

/// Drips what a particle holds above its capacity. Returns the dripped mass.
inline double drip(double capacity, double* held) {
  if (*held <= capacity) return 0.0;
  const double gone = *held - capacity;
  *held = capacity;
  return gone;
}

/// Seconds of [t0, t1) that a source or dryer on during [start, stop) is on.
inline double overlapSeconds(double start, double stop, double t0, double t1) {
  const double a = start > t0 ? start : t0;
  const double b = stop < t1 ? stop : t1;
  return b > a ? b - a : 0.0;
}

/// Advances the water by dt from time t0 (state->time_s is not read: the caller passes the frame's
/// start): sources, exchange between strands in contact, wicking and gravity flow, drip,
/// evaporation; then writes saturation = held / capacity clamped to [0, 1] and adds to
/// state->water_ledger. Positions are read, never written. `gravity_m_s2` gives the flow's
/// direction and scale. Call reconcileWater first if something else set the saturation.
void stepWater(const HairModel& model, const WaterConfig& config, const WaterSources& sources,
               const Vec3& gravity_m_s2, double t0, double dt, HairState* state,
               WaterStepStats* stats);

/// Makes the held water agree with a saturation set from outside (a command, the scene's
/// initial ramp): every particle whose saturation differs from clamp(held / capacity) gets
/// held = saturation x capacity, and the difference is booked as water added (or removed, when
/// the command dried it), so that the ledger still balances. Returns the particles changed.
int reconcileWater(const HairModel& model, const WaterConfig& config, HairState* state);

/// Sets every particle's mass to its dry mass (rho times its length share) plus the water it
/// holds, and the inverse mass of the non-root particles to match (roots stay kinematic). The
/// stability bounds stay those of the dry masses, which heavier particles only loosen. The
/// bending damping ratio falls as 1 / sqrt(mass): a strand at the flutter bound when dry
/// (kMinBendDampingRatio) is below it soaked; the defaults are at critical dry, 0.71 at a full
/// load of water at the default capacity.
void applyWaterMass(const HairState& state, HairModel* model);

/// Water held by the hair, kg (sum over particles).
double heldWater(const HairState& state);

/// Mean saturation over the particles.
double meanSaturation(const HairState& state);

}  // namespace wet_curly_hair

// Pieces of the step shared by solver.cpp and the strand-block stepper (strand_block.h).
// Private to the core library.
#pragma once

#include <cstdint>
#include <limits>

#include "wet_curly_hair/core/lane_math.h"
#include "wet_curly_hair/core/solver.h"
#include "wet_curly_hair/core/state.h"

namespace wet_curly_hair {
namespace detail {

/// Lap timer over the stages of one strand-substep: one clock read per stage, none without a
/// clock. Always counts the particles each stage ran on.
class StageLaps {
 public:
  StageLaps(ClockFn clock, StepStats* stats) : clock_(clock), stats_(stats) {
    if (clock_) last_ = clock_();
  }
  void lap(int stage, uint64_t particles) {
    stats_->stage_particles[stage] += particles;
    if (!clock_) return;
    const double now = clock_();
    stats_->stage_cpu_s[stage] += now - last_;
    last_ = now;
  }
  /// Starts the next lap without charging the time since the last one to any stage.
  void skip() {
    if (clock_) last_ = clock_();
  }

 private:
  ClockFn clock_;
  StepStats* stats_;
  double last_ = 0.0;
};

/// The head's rigid motion over one substep, the same for every strand of the step.
struct SubstepMotion {
  Pose pose0;  ///< head -> world at the start of the substep.
  Pose pose1;  ///< and at its end.
  Mat3 r0, r1, r1_inverse;
  Vec3 omega = Vec3::Zero();          ///< angular velocity over the substep, world frame.
  Vec3 head_velocity = Vec3::Zero();  ///< velocity of the head origin.
};

/// What a step does, resolved once per step from the configuration's strings and the substep.
struct SolverPlan {
  double theta = 0.0;                 ///< integratorTheta; 0 for the explicit method.
  bool implicit = false;              ///< theta > 0.
  bool curl_spring = true;            ///< CurlConfig::mode "spring" (else "literal").
  bool inelastic_limit = false;       ///< SolverConfig::inelasticStrainLimit.
  bool bend_frame_gradient = false;   ///< BendConfig::frame_gradient, with bending on.
  bool core_filter_gradient = false;  ///< CoreSpringConfig::filter_gradient.
  bool force_cohesion = false;        ///< CohesionConfig::mode "lin" or "kim".
  bool lanes = true;                  ///< IntegratorConfig::strand_lanes.
  int lane_width = 8;                 ///< strands per block (IntegratorConfig::laneWidth()).
  bool lane_float = true;             ///< the lanes compute in float.
  int damping_passes = 1;             ///< explicit damping passes (dampingPassCount).
  /// Eq. (13)'s velocity factor of a dry particle at substep h: the same for every strand, so
  /// formed once per step (a pow per strand was 1.4 % of the step at 10,000 strands).
  double dry_velocity_factor = 1.0;
};
SolverPlan planStep(const HairModel& model, const SolverConfig& config, double h);

/// The post-step check's two laws, for one strand in double (strandFinite, strandStrainOk) and
/// for a block's lanes as they leave them (scatterStateByRow) alike. A value is finite when its
/// magnitude is at most the largest double (a NaN compares false).
template <typename S>
WCH_INLINE LaneMask<S> finiteValue(const S& x) {
  return vmax(x, -x) <= splat<S>(std::numeric_limits<double>::max());
}
/// An edge (dx, dy, dz) is longer than `longest` (squared lengths: no square root per edge; a
/// NaN length is not, the finiteness check catches it).
template <typename S>
WCH_INLINE LaneMask<S> edgeLongerThan(const S& dx, const S& dy, const S& dz, const S& longest) {
  return dx * dx + dy * dy + dz * dz > longest * longest;
}

/// True when the n positions and velocities are all finite (finiteValue); adds the count of
/// non-finite scalars to `nonfinite`.
bool strandFinite(const Vec3* position, const Vec3* velocity, int n, uint64_t* nonfinite);

/// False when an edge of strand s, at the positions `position` (its n particles), is longer than
/// 3x the strain limit allows: the post-step check (commitStrandAfterStep) then restores the
/// strand and counts a strain repair.
bool strandStrainOk(const HairModel& model, const SolverConfig& config, int s,
                    const Vec3* position);
/// strandStrainOk at the state's positions.
bool strandStrainOk(const HairModel& model, const SolverConfig& config, int s,
                    const HairState& state);

/// Strand s after its block's substeps (the whole step; one substep where strands are coupled),
/// its positions and velocities not yet in the state (`position`, `velocity`: its n particles).
/// Written to the state when healthy. Otherwise (a non-finite value, or a strain beyond 3x the
/// limit) counted in `stats`, and the strand restored from the state, which still holds what it
/// started from at pose `from`: carried rigidly by the head to `to`, or, where that starting
/// state fails the same check (a caller wrote it between steps), its rest shape carried by the
/// head, with the head's velocity over elapsed_s. So the restore point costs no copy: the last
/// good state, copied for every strand at every step, took 0.05 of the 0.47 CPU s per simulated
/// second of the gather, scatter and check at 10,000 strands on two threads (docs/physics.md §3).
/// The strand-block stepper runs it on each strand of a block right after converting it from the
/// lanes, while it is in cache.
void commitStrandAfterStep(const HairModel& model, const SolverConfig& config, const Pose& from,
                           const Pose& to, double elapsed_s, int s, const Vec3* position,
                           const Vec3* velocity, HairState* state, StepStats* stats);

/// Fills the per-strand quantities that stay constant through a step's substeps into `scratch`
/// (the eq. 13 velocity factors), from the state's kept factors where their inputs are unchanged
/// (HairState::stiffness_factor).
void prepareStrandStep(const HairModel& model, const SolverConfig& config, const SolverPlan& plan,
                       int strand, const StrandFlags& flags, double h, HairState* state,
                       StrandScratch* scratch);

/// How far M moves toward its target in a substep of h: 1 - exp(-h / tau) for the time constant
/// tau = CurlConfig::rotation_time_constant_s, 1 (at once) for tau = 0.
double curlFollowFraction(const CurlConfig& config, double h);

/// Strands whose curl rotations updateCurlRotations takes at once.
constexpr int kCurlFilterWidth = 16;

/// Eqs. (7)-(8), A8, for strand[l] of the lanes l < count (at most kCurlFilterWidth) with
/// update[l]: moves the strand's curl rotation M toward the one taking its helix axis onto the
/// root-to-tip vector by follow_fraction (curlFollowFraction; a slerp, at once for 1); kept when
/// the strand curls back onto its root (curl_filter.cpp).
void updateCurlRotations(const HairModel& model, const int* strand, const Vec3* root_to_tip,
                         const bool* update, int count, double follow_fraction, HairState* state);

SubstepMotion substepMotion(const StepInputs& inputs, double s0, double s1, double h);

/// True when eq. (13) changes the velocities of a strand with these flags.
bool stiffnessActive(const SolverConfig& config, const StrandFlags& flags);

/// The widest block of strands advanced together, one per SIMD lane.
constexpr int kMaxStrandLanes = 16;
static_assert(kMaxStrandLanes <= StrandScratch::kBlockStrands, "a block's strands fit the scratch");

/// The strands from first_strand on (at most width, fewer in the last block) when they all have
/// the same particle count (at least 2), so that they can run as one block; 0 when they cannot.
int blockStrands(const HairModel& model, int first_strand, int width);
/// The width a block of `active` strands (from blockStrands) runs at in a layout of `width`
/// lanes: a partial block that fits in half the lanes of a layout that has a half (float16 to
/// float8, double8 to double4) runs there, on half the padding.
inline int blockRunWidth(int width, int active, bool lane_float) {
  const bool half = active <= width / 2 && (width == 16 || (width == 8 && !lane_float));
  return half ? width / 2 : width;
}

/// Substeps k_begin .. k_end - 1 of a step of nsub substeps for the block of `active` strands
/// from first_strand (at most `width`; flags: one per lane, the padding lanes repeating the last
/// strand's) in lanes of `width` doubles (1: one strand at a time, the reference path; 4; 8) or
/// floats (8, 16): strand_block.h, instantiated in strand_block_double.cpp and
/// strand_block_float.cpp. `scratch` is the thread's; returns the largest strain before limiting.
double stepStrandBlockDouble(int width, const HairModel& model, const SolverConfig& config,
                             const SolverPlan& plan, const StepInputs& inputs, int first_strand,
                             int active, const StrandFlags* flags, int k_begin, int k_end, int nsub,
                             double h, HairState* state, StrandScratch* scratch, StepStats* stats);
double stepStrandBlockFloat(int width, const HairModel& model, const SolverConfig& config,
                            const SolverPlan& plan, const StepInputs& inputs, int first_strand,
                            int active, const StrandFlags* flags, int k_begin, int k_end, int nsub,
                            double h, HairState* state, StrandScratch* scratch, StepStats* stats);

}  // namespace detail
}  // namespace wet_curly_hair

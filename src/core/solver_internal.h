// Pieces of the substep shared by the scalar strand path (solver.cpp) and the strand-lane block
// path (solver_lanes.cpp). Private to the core library.
#pragma once

#include <cstdint>

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

/// Eqs. (7)-(8), A8: moves strand's curl rotation M toward the one taking its helix axis onto the
/// root-to-tip direction (time constant CurlConfig::rotation_time_constant_s); kept when the
/// strand curls back onto its root.
void updateCurlRotation(const HairModel& model, const CurlConfig& config, int strand,
                        const Vec3& root, const Vec3& tip, double h, HairState* state);

SubstepMotion substepMotion(const StepInputs& inputs, double s0, double s1, double h);

/// True when eq. (13) changes the velocities of a strand with these flags.
bool stiffnessActive(const SolverConfig& config, const StrandFlags& flags);

/// Head collision (§6) of particles 1..n-1 of one strand: projection to the offset surface,
/// inelastic, Coulomb friction, the head's velocity at the particle from the two poses.
/// Returns the contacts.
uint64_t collideHeadParticles(const HairModel& model, const CollisionConfig& config,
                              const SubstepMotion& motion, double h, Vec3* p, Vec3* v, int n);

/// The same against the (static, world-frame) external obstacles.
uint64_t collideObstacleParticles(const Obstacles& obstacles, const ObstacleCollisionConfig& config,
                                  Vec3* p, Vec3* v, int n);

/// Strain limiting root -> tip with velocity correction (Selle 2008, §2.2b). Returns the edges it
/// projected; the largest strain it found goes to *max_strain.
uint64_t limitStrainEdges(const StretchConfig& config, const double* rest, double h, Vec3* p,
                          Vec3* v, int n, double* max_strain);

/// Further collision + limit rounds after a substep's first (CollisionConfig::constraint_rounds):
/// only where something touched and the limit then moved a particle. Returns the rounds run.
uint64_t extraConstraintRounds(const HairModel& model, const SolverConfig& config,
                               const Obstacles* obstacles, bool obstacle_collision,
                               const SubstepMotion& motion, const double* rest, double h,
                               uint64_t touched, uint64_t projected, Vec3* p, Vec3* v, int n);

/// The widest block of strands advanced together, one per SIMD lane, by stepStrandBlock.
constexpr int kMaxStrandLanes = 16;

/// The strands from first_strand on (at most width, fewer in the last block) when they all have
/// the same particle count (at least 2), so that they can run as one block; 0 when they cannot.
int blockStrands(const HairModel& model, int first_strand, int width);

/// All nsub substeps of a step for the block of `active` (at most IntegratorConfig::laneWidth())
/// strands starting at first_strand (flags: one per strand), as substepStrand would advance each
/// of them, in the configured lane layout; a partial block runs with the lanes beyond it
/// repeating its last strand, in the half-width layout of the same precision when it fits
/// (solver_lanes.cpp). `scratch` is the thread's; returns the largest strain before limiting.
double stepStrandBlock(const HairModel& model, const SolverConfig& config, const StepInputs& inputs,
                       int first_strand, int active, const StrandFlags* flags, int nsub, double h,
                       HairState* state, StrandScratch* scratch, StepStats* stats);

}  // namespace detail
}  // namespace wet_curly_hair

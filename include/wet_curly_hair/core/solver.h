// The step: a recipe of stages over each strand (docs/physics.md §9.2), time injected by the
// caller.
#pragma once

#include <cstdint>

#include "wet_curly_hair/core/config.h"
#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/obstacles.h"
#include "wet_curly_hair/core/state.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// A monotonic clock in seconds, supplied by the caller: the core never reads a clock itself.
using ClockFn = double (*)();

/// What the world tells the solver for one step.
struct StepInputs {
  Pose head_start;  ///< head -> world at the start of the step.
  Pose head_end;    ///< head -> world at the end; roots are interpolated at every substep.
  const Obstacles* obstacles = nullptr;  ///< external obstacles (world frame); null: none.
  /// When set, every stage of the step is timed with it (StepStats::stage_cpu_s). Costs one
  /// clock read per stage and strand-substep (block-substep with strand lanes; ~2 % of a dry
  /// explicit substep, measured in bench/wet_curly_hair_bench).
  ClockFn clock = nullptr;
};

/// The stages of a step, in the order they run ("model only what a scene needs": each reports
/// how many particles it touched and how long it took).
enum Stage : int {
  kStageFrames = 0,         ///< smoothed curves, frames, bend targets (per substep)
  kStageForces,             ///< gravity, stretch, bend and core springs (per substep)
  kStageCurl,               ///< curl exaggeration, wet strands (per substep)
  kStageAdhesion,           ///< adhesion, wet particles within obstacle reach (per substep)
  kStageIntegrate,          ///< velocity update with damping (explicit) or the implicit solve
  kStageHeadCollision,      ///< head collision (per substep)
  kStageObstacleCollision,  ///< obstacle collision, strands within reach (per substep)
  kStageStrainLimit,        ///< strain limiting (per substep)
  kStageRepair,             ///< finite/strain checks and repairs (per step)
  kStageCohesion,           ///< stable cohesion display positions (per step)
  kStageCohesionForces,     ///< force-based baselines lin/kim (per substep, all strands)
  kStageHairContact,        ///< hair-hair contact forces (per substep, spheres; hair_contact.h)
  kStageFollowers,          ///< followers placed from their guides (per step, followers.h)
  /// the strands' state and constants into their SIMD blocks and back, and the step's per-strand
  /// setup (per step; particles once per step)
  kStageLanes,
  kStageCount
};

/// Stable snake_case name of a stage ("frames", "forces", ...).
const char* stageName(int stage);

/// Counters of one step (what ran, what was clamped, what was repaired).
struct StepStats {
  int substeps = 0;
  double substep_s = 0.0;
  double max_strain_before_limit = 0.0;  ///< largest edge strain before the limiter projected it.
  uint64_t strain_limited_edges = 0;     ///< edge projections by the strain limiter.
  uint64_t velocity_clamps = 0;          ///< velocity clamps in the damping pass.
  uint64_t head_contacts = 0;            ///< particle-substeps in contact with the head.
  /// Extra collision + strain-limit rounds run (strand-substeps x rounds; CollisionConfig).
  uint64_t constraint_rounds = 0;
  /// Strands restored after the step (the post-step check, step()): those with a non-finite
  /// position or velocity plus those with an edge beyond 3x the strain limit, and the non-finite
  /// scalars the first held.
  uint64_t repaired_strands = 0, nonfinite_repairs = 0, strain_repairs = 0, nonfinite_values = 0;
  /// Of the repaired strands, those given their rest shape: the state they started the step from
  /// failed the same check (written so by a caller between steps).
  uint64_t rest_shape_repairs = 0;
  uint64_t head_jumps = 0;  ///< 1 when this step's head motion was taken as a jump.
  // What ran, per stage ("model only what a scene needs"): particle-substeps or particles.
  uint64_t curl_particle_substeps = 0;      ///< curl exaggeration (wet strands only).
  uint64_t adhesion_particle_substeps = 0;  ///< adhesion evaluated (wet, within obstacle reach).
  uint64_t adhesion_active = 0;             ///< of those, inside the kernel band (pulled).
  uint64_t obstacle_particle_substeps = 0;  ///< obstacle distance evaluated (within reach).
  uint64_t obstacle_contacts = 0;           ///< particle-substeps in contact with an obstacle.
  uint64_t cohesion_particles = 0;          ///< wet particles that found cross-strand neighbours.
  uint64_t wet_strands = 0;                 ///< strands with any saturation.
  uint64_t strands_near_obstacles = 0;      ///< strands whose reach touches an obstacle.
  /// Hair-hair contact (hair_contact.h): sphere pairs of different strands touching at the last
  /// substep, strands with a contact force at the last substep, and Verlet list builds.
  uint64_t hair_contacts = 0;
  uint64_t hair_contact_strands = 0;
  uint64_t hair_contact_list_builds = 0;
  uint64_t hair_contact_listed_pairs = 0;  ///< sphere pairs in the Verlet list (last substep).
  /// Per stage: particles it ran on (particle-substeps for per-substep stages, particles for
  /// per-step ones) and seconds of inputs.clock (only with it): summed over the solver threads
  /// for the stages timed inside a block or strand (frames to strain_limit, repair, lanes), and
  /// the wall time of the whole parallel pass, read on the calling thread, for those run as one
  /// (followers, cohesion, cohesion_forces, hair_contact): there two threads halve the figure.
  uint64_t stage_particles[kStageCount] = {};
  double stage_cpu_s[kStageCount] = {};
  double wall_s = 0.0;  ///< the whole step, wall clock (only with inputs.clock).
  /// Adds the counters of `o` (sums; maxima for max_strain_before_limit).
  void accumulate(const StepStats& o);
};

/// Number of equal substeps a step of dt_s is split into so that none exceeds config's substep_s
/// (nor, with hair contact on, hair_contact.max_substep_s). For the explicit integrator, buildModel
/// and updateSpringConstants refuse a substep_s past the groom's stability bound
/// (checkExplicitSubstep, model.h): it is never shortened here.
int substepCount(const SolverConfig& config, double dt_s);

/// Damping passes used for substep h: config's minimum, raised until tau = h / n satisfies the
/// explicit damping bound tau <= 0.9 / (2 max(c / m)) (HairModel::max_damping_per_mass).
int dampingPassCount(const HairModel& model, const SolverConfig& config, double h);

/// Advances the state by dt_s (one output frame, split into equal substeps). Nothing is allocated.
/// After the step, each strand with a non-finite value or a strain beyond 3x the limit is
/// restored to the state it started the step from, carried rigidly by the head, and counted
/// (state->warnings, stats->repaired_strands); a strand whose starting state fails the same check
/// (a caller wrote it so between steps) takes its rest shape carried by the head instead
/// (stats->rest_shape_repairs). Where strands are coupled (hair contact, the force-based cohesion
/// baselines) every substep is checked, and a strand restored to that substep's start.
void step(const HairModel& model, const SolverConfig& config, const StepInputs& inputs, double dt_s,
          HairState* state, StepStats* stats);

/// Per-strand flags of one step: which optional stages the strand needs.
struct StrandFlags {
  bool wet = false;             ///< any particle with saturation > 0.
  bool near_obstacle = false;   ///< the strand can reach an obstacle within the margin.
  bool external_force = false;  ///< state->external_force holds cross-strand forces.
};

/// Theta of the implicit methods (1 backward Euler, 1/2 midpoint); 0 for "explicit".
double integratorTheta(const IntegratorConfig& config);

}  // namespace wet_curly_hair

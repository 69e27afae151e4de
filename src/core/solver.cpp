#include "wet_curly_hair/core/solver.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "parallel.h"
#include "solver_internal.h"
#include "wet_curly_hair/core/cohesion.h"
#include "wet_curly_hair/core/followers.h"
#include "wet_curly_hair/core/frames.h"
#include "wet_curly_hair/core/hair_contact.h"
#include "wet_curly_hair/core/head_collider.h"
#include "wet_curly_hair/core/smoothing.h"
#include "wet_curly_hair/core/springs.h"
#include "wet_curly_hair/core/wet_kernels.h"

namespace wet_curly_hair {

int substepCount(const SolverConfig& config, double dt_s) {
  if (!(dt_s > 0.0)) return 0;
  const double longest = config.hair_contact.enabled ? std::min(config.integrator.substep_s,
                                                                config.hair_contact.max_substep_s)
                                                     : config.integrator.substep_s;
  return std::max(1, static_cast<int>(std::ceil(dt_s / longest - 1e-9)));
}

int dampingPassCount(const HairModel& model, const SolverConfig& config, double h) {
  int passes = config.integrator.damping_passes;
  if (model.max_damping_per_mass > 0.0) {
    const double tau_max = 0.9 / (2.0 * model.max_damping_per_mass);
    passes = std::max(passes, static_cast<int>(std::ceil(h / tau_max)));
  }
  return passes;
}

double integratorTheta(const IntegratorConfig& config) {
  if (config.method == "backward_euler") return 1.0;
  if (config.method == "midpoint") return 0.5;
  if (config.method == "theta") return config.theta;
  return 0.0;
}

const char* stageName(int stage) {
  static const char* const kNames[kStageCount] = {"frames",
                                                  "forces",
                                                  "curl",
                                                  "adhesion",
                                                  "integrate",
                                                  "head_collision",
                                                  "obstacle_collision",
                                                  "strain_limit",
                                                  "repair",
                                                  "cohesion",
                                                  "cohesion_forces",
                                                  "hair_contact",
                                                  "followers",
                                                  "lanes"};
  return stage >= 0 && stage < kStageCount ? kNames[stage] : "unknown";
}

void StepStats::accumulate(const StepStats& o) {
  max_strain_before_limit = std::max(max_strain_before_limit, o.max_strain_before_limit);
  strain_limited_edges += o.strain_limited_edges;
  velocity_clamps += o.velocity_clamps;
  head_contacts += o.head_contacts;
  constraint_rounds += o.constraint_rounds;
  repaired_strands += o.repaired_strands;
  nonfinite_repairs += o.nonfinite_repairs;
  nonfinite_values += o.nonfinite_values;
  strain_repairs += o.strain_repairs;
  rest_shape_repairs += o.rest_shape_repairs;
  curl_particle_substeps += o.curl_particle_substeps;
  adhesion_particle_substeps += o.adhesion_particle_substeps;
  adhesion_active += o.adhesion_active;
  obstacle_particle_substeps += o.obstacle_particle_substeps;
  obstacle_contacts += o.obstacle_contacts;
  cohesion_particles += o.cohesion_particles;
  wet_strands += o.wet_strands;
  strands_near_obstacles += o.strands_near_obstacles;
  hair_contacts += o.hair_contacts;
  hair_contact_strands += o.hair_contact_strands;
  hair_contact_list_builds += o.hair_contact_list_builds;
  hair_contact_listed_pairs = std::max(hair_contact_listed_pairs, o.hair_contact_listed_pairs);
  for (int k = 0; k < kStageCount; ++k) {
    stage_particles[k] += o.stage_particles[k];
    stage_cpu_s[k] += o.stage_cpu_s[k];
  }
}

namespace detail {

bool stiffnessActive(const SolverConfig& config, const StrandFlags& flags) {
  const StiffnessConfig& st = config.stiffness;
  return st.global_factor < 1.0 || (flags.wet && st.wet_factor < 1.0) || st.dry_factor < 1.0;
}

SubstepMotion substepMotion(const StepInputs& inputs, double s0, double s1, double h) {
  SubstepMotion m;
  m.pose0 = interpolate(inputs.head_start, inputs.head_end, s0);
  m.pose1 = interpolate(inputs.head_start, inputs.head_end, s1);
  const Eigen::AngleAxisd turn(m.pose1.rotation * m.pose0.rotation.conjugate());
  m.omega = turn.axis() * (turn.angle() / h);
  m.head_velocity = (m.pose1.translation - m.pose0.translation) / h;
  // Rotation matrices once per substep instead of a quaternion product per particle.
  m.r0 = m.pose0.rotation.toRotationMatrix();
  m.r1 = m.pose1.rotation.toRotationMatrix();
  m.r1_inverse = m.r1.transpose();
  return m;
}

double curlFollowFraction(const CurlConfig& config, double h) {
  const double tc = config.rotation_time_constant_s;
  return tc > 0.0 ? 1.0 - std::exp(-h / tc) : 1.0;
}

int blockStrands(const HairModel& model, int first_strand, int width) {
  const int count = std::min(width, model.simulatedStrandCount() - first_strand);
  if (count < 1) return 0;
  const int n = model.strandSize(first_strand);
  if (n < 2) return 0;
  for (int l = 1; l < count; ++l)
    if (model.strandSize(first_strand + l) != n) return 0;
  return count;
}

void prepareStrandStep(const HairModel& model, const SolverConfig& config, const SolverPlan& plan,
                       int strand, const StrandFlags& flags, double h, HairState* state,
                       StrandScratch* scratch) {
  if (!stiffnessActive(config, flags)) return;
  const StiffnessConfig& st = config.stiffness;
  const int begin = model.strandBegin(strand);
  const double dry = plan.dry_velocity_factor;
  // A particle's factor from the last step stands while its saturation and the strand's other
  // inputs are the same: the same function of the same values.
  StiffnessFactorKey key;
  key.global_factor = st.global_factor;
  key.wet_factor = st.wet_factor;
  key.dry_factor = st.dry_factor;
  key.substep_s = h;
  key.reference_step_s = st.reference_step_s;
  const bool same_key = state->stiffness_factor_key[strand] == key;
  state->stiffness_factor_key[strand] = key;
  const int n = model.strandSize(strand);
  if (same_key) {
    // Where every wet particle's factor stands (the common case), the loop below in two passes
    // without a branch per particle: the same values.
    const double* sigma = &state->saturation[begin];
    const double* held_at = &state->stiffness_factor_saturation[begin];
    const double* held = &state->stiffness_factor[begin];
    int stale = 0;
    for (int i = 0; i < n; ++i) stale += (sigma[i] > 0.0) & (held_at[i] != sigma[i]);
    if (stale == 0) {
      for (int i = 0; i < n; ++i) scratch->velocity_factor[i] = sigma[i] > 0.0 ? held[i] : dry;
      return;
    }
  }
  for (int i = 0; i < n; ++i) {
    const int k = begin + i;
    const double sigma = state->saturation[k];
    if (!(sigma > 0.0)) {
      scratch->velocity_factor[i] = dry;
      continue;
    }
    if (!same_key || state->stiffness_factor_saturation[k] != sigma) {
      state->stiffness_factor[k] = stiffnessFactor(st.global_factor, st.wet_factor, st.dry_factor,
                                                   sigma, h, st.reference_step_s);
      state->stiffness_factor_saturation[k] = sigma;
    }
    scratch->velocity_factor[i] = state->stiffness_factor[k];
  }
}

bool strandStrainOk(const HairModel& model, const SolverConfig& config, int s,
                    const Vec3* position) {
  const int begin = model.strandBegin(s);
  const int edges = model.strandSize(s) - 1;
  const double bound = 1.0 + 3.0 * config.stretch.strain_limit;
  const double* __restrict p = position->data();
  const double* __restrict rest = &model.rest_edge_m[begin];
  // Counted without a branch per edge; a square root per edge, waited on, cost 1.7 % of a
  // one-thread step at 10,000 strands (edgeLongerThan compares squares).
  int too_long = 0;
  for (int i = 0; i < edges; ++i) {
    const double dx = p[3 * i + 3] - p[3 * i], dy = p[3 * i + 4] - p[3 * i + 1],
                 dz = p[3 * i + 5] - p[3 * i + 2];
    too_long += edgeLongerThan(dx, dy, dz, bound * rest[i]);
  }
  return too_long == 0;
}

bool strandStrainOk(const HairModel& model, const SolverConfig& config, int s,
                    const HairState& state) {
  return strandStrainOk(model, config, s, &state.position[model.strandBegin(s)]);
}

SolverPlan planStep(const HairModel& model, const SolverConfig& config, double h) {
  SolverPlan plan;
  plan.theta = integratorTheta(config.integrator);
  plan.implicit = plan.theta > 0.0;
  plan.curl_spring = config.curl.mode == "spring";
  plan.inelastic_limit = config.inelasticStrainLimit();
  plan.bend_frame_gradient = config.bend.frame_gradient && config.bend.stiffness_n_m2 > 0.0;
  plan.core_filter_gradient = config.core.filter_gradient;
  plan.force_cohesion = config.cohesion.mode == "lin" || config.cohesion.mode == "kim";
  plan.lanes = config.integrator.strand_lanes;
  plan.lane_width = config.integrator.laneWidth();
  plan.lane_float = config.integrator.laneFloat();
  plan.damping_passes = plan.implicit ? 0 : dampingPassCount(model, config, h);
  const StiffnessConfig& st = config.stiffness;
  plan.dry_velocity_factor =
      stiffnessFactor(st.global_factor, st.wet_factor, st.dry_factor, 0.0, h, st.reference_step_s);
  return plan;
}

}  // namespace detail

using detail::SolverPlan;

namespace {

/// Non-finite scalars among the 3 n coordinates of v (a count without a branch per value, so that
/// it vectorises: |x| <= max is false for infinities and NaN alike).
uint64_t countNonfinite(const Vec3* v, int n) {
  const double* __restrict x = v->data();
  uint64_t count = 0;
  for (int k = 0; k < 3 * n; ++k) count += !detail::finiteValue(x[k]);
  return count;
}

}  // namespace

bool detail::strandFinite(const Vec3* position, const Vec3* velocity, int n, uint64_t* nonfinite) {
  const uint64_t count = countNonfinite(position, n) + countNonfinite(velocity, n);
  *nonfinite += count;
  return count == 0;
}

namespace {

StrandFlags strandFlags(const HairModel& model, const SolverConfig& config,
                        const StepInputs& inputs, int s, const HairState& state) {
  StrandFlags flags;
  const int begin = model.strandBegin(s);
  for (int i = begin; i < begin + model.strandSize(s); ++i)
    flags.wet = flags.wet || state.saturation[i] > 0.0;
  if (inputs.obstacles && !inputs.obstacles->empty()) {
    // The strand stays within its length of its root during the step (roots move with the head:
    // test both ends of the root's path).
    Vec3 normal;
    const double reach = model.strand_length_m[s] + config.obstacle.margin_m +
                         std::max(config.obstacle.offset_m, config.adhesion.radius_m);
    const Vec3 r0 = inputs.head_start.apply(model.rest_position_head[begin]);
    const Vec3 r1 = inputs.head_end.apply(model.rest_position_head[begin]);
    const double travel = (r1 - r0).norm();
    flags.near_obstacle = inputs.obstacles->distance(r0, &normal) <= reach + travel;
  }
  return flags;
}

/// Restores strand s, whose step went wrong, from the state it started the step from (still in
/// `state`: the step's result was never written there), carried rigidly by the head from `from`
/// to `to`. Where that state is itself unhealthy (a caller wrote it between steps), the strand
/// takes its rest shape carried by the head instead, moving with the head (elapsed_s from `from`
/// to `to`). Returns whether it fell back to the rest shape.
bool restoreStrand(const HairModel& model, const SolverConfig& config, const Pose& from,
                   const Pose& to, double elapsed_s, int s, HairState* state) {
  const int begin = model.strandBegin(s);
  const int n = model.strandSize(s);
  Vec3* position = &state->position[begin];
  Vec3* velocity = &state->velocity[begin];
  uint64_t ignored = 0;
  const bool start_healthy = detail::strandFinite(position, velocity, n, &ignored) &&
                             detail::strandStrainOk(model, config, s, position);
  for (int i = 0; i < n; ++i) {
    if (start_healthy) {
      position[i] = to.apply(from.applyInverse(position[i]));
      velocity[i] = to.rotate(from.rotation.conjugate() * velocity[i]);
    } else {
      const Vec3& rest = model.rest_position_head[begin + i];
      position[i] = to.apply(rest);
      velocity[i] = (position[i] - from.apply(rest)) / elapsed_s;
    }
  }
  return !start_healthy;
}

}  // namespace

void detail::commitStrandAfterStep(const HairModel& model, const SolverConfig& config,
                                   const Pose& from, const Pose& to, double elapsed_s, int s,
                                   const Vec3* position, const Vec3* velocity, HairState* state,
                                   StepStats* stats) {
  const int n = model.strandSize(s);
  uint64_t nonfinite = 0;
  const bool finite = detail::strandFinite(position, velocity, n, &nonfinite);
  if (finite && detail::strandStrainOk(model, config, s, position)) {
    const int begin = model.strandBegin(s);
    std::memcpy(state->position[begin].data(), position->data(), n * sizeof(Vec3));
    std::memcpy(state->velocity[begin].data(), velocity->data(), n * sizeof(Vec3));
    return;
  }
  stats->rest_shape_repairs += restoreStrand(model, config, from, to, elapsed_s, s, state);
  ++stats->repaired_strands;
  if (!finite) {
    ++stats->nonfinite_repairs;
    stats->nonfinite_values += nonfinite;
  } else {
    ++stats->strain_repairs;
  }
}

namespace {

/// A head that jumps within a step (faster than any head moves: a teleport, a tracking glitch)
/// carries the hair rigidly with it first, velocities turned with it; the step then sees a still
/// head. Returns the inputs the step runs with.
StepInputs carryHairThroughHeadJump(const HairModel& model, const SolverConfig& config,
                                    const StepInputs& inputs, double dt_s, HairState* state,
                                    StepStats* stats) {
  const IntegratorConfig& ic = config.integrator;
  const double travel = (inputs.head_end.translation - inputs.head_start.translation).norm();
  const double turn =
      Eigen::AngleAxisd(inputs.head_end.rotation * inputs.head_start.rotation.conjugate()).angle();
  const bool jumped = (ic.teleport_speed_m_s > 0.0 && travel > ic.teleport_speed_m_s * dt_s) ||
                      (ic.teleport_angle_rad > 0.0 && turn > ic.teleport_angle_rad);
  if (!jumped) return inputs;
  const Pose jump = inputs.head_end * inputs.head_start.inverse();
  for (int i = 0; i < model.particleCount(); ++i) {
    state->position[i] = jump.apply(state->position[i]);
    state->velocity[i] = jump.rotation * state->velocity[i];
  }
  for (int s = 0; s < model.strandCount(); ++s)
    state->curl_rotation[s] = (jump.rotation * state->curl_rotation[s]).normalized();
  StepInputs carried = inputs;
  carried.head_start = inputs.head_end;
  stats->head_jumps = 1;
  ++state->warnings.head_jumps;
  return carried;
}

/// Runs the strand-block stepper in the plan's layout (width 1: one strand at a time).
double stepBlock(int width, const HairModel& model, const SolverConfig& config,
                 const SolverPlan& plan, const StepInputs& inputs, int first, int active,
                 const StrandFlags* flags, int k_begin, int k_end, int nsub, double h,
                 HairState* state, StrandScratch* scratch, StepStats* stats) {
  if (width > 1 && plan.lane_float)
    return detail::stepStrandBlockFloat(width, model, config, plan, inputs, first, active, flags,
                                        k_begin, k_end, nsub, h, state, scratch, stats);
  return detail::stepStrandBlockDouble(width, model, config, plan, inputs, first, active, flags,
                                       k_begin, k_end, nsub, h, state, scratch, stats);
}

/// Strands couple only through per-step outputs: each block of strands runs substeps
/// [k_begin, k_end) at once, while its particles stay in cache; blocks are shared among the
/// threads. Blocks of plan.lane_width strands of equal size run in SIMD lanes (fixed by strand
/// index, so the result does not depend on the thread count); a lone strand, a block of unequal
/// sizes, or every strand without lanes runs one at a time. `external` (per strand, or null):
/// state->external_force holds cross-strand forces for that strand.
void advanceStrands(const HairModel& model, const SolverConfig& config, const SolverPlan& plan,
                    const StepInputs& inputs, int k_begin, int k_end, int nsub, double h,
                    int threads, const uint8_t* external, HairState* state, StepStats* per_thread) {
  const int strands = model.simulatedStrandCount();
  const int width = plan.lanes ? plan.lane_width : 1;
  const int blocks = (strands + width - 1) / width;
  // One block per grab: with 16 strands per block, 100 strands are 7 blocks, and chunks of two
  // left one thread four blocks against three.
  detail::parallelFor(threads, detail::Schedule::kDynamic, 1, blocks, [&](int blk) {
    const int t = detail::threadIndex();
    StepStats& ts = per_thread[t];
    const int first = blk * width;
    StrandFlags flags[detail::kMaxStrandLanes];
    auto run = [&](int block_width, int first_strand, int active) {
      for (int l = 0; l < active; ++l) {
        flags[l] = strandFlags(model, config, inputs, first_strand + l, *state);
        flags[l].external_force = external && external[first_strand + l];
        if (k_begin > 0) continue;  // counted once per step
        ts.wet_strands += flags[l].wet;
        ts.strands_near_obstacles += flags[l].near_obstacle;
      }
      std::fill(flags + active, flags + block_width, flags[active - 1]);  // the padding lanes
      const double strain =
          stepBlock(block_width, model, config, plan, inputs, first_strand, active, flags, k_begin,
                    k_end, nsub, h, state, &state->scratch[t], &ts);
      ts.max_strain_before_limit = std::max(ts.max_strain_before_limit, strain);
    };
    // A partial last block of two or more runs in lanes (the strand count need not be a
    // multiple of the width), in the half-width layout of the same precision when it fits: the
    // same operations lane by lane, so the same result, on half the padding.
    const int active = width > 1 ? detail::blockStrands(model, first, width) : 0;
    if (active >= 2) {
      run(detail::blockRunWidth(width, active, plan.lane_float), first, active);
    } else {
      for (int s = first; s < std::min(strands, first + width); ++s) run(1, s, 1);
    }
  });
}

/// Cross-strand forces of one substep into state->external_force: the force-based cohesion
/// baselines (lin/kim) and hair-hair contact. Returns the per-strand flags of who has one
/// (null: every strand, the baselines).
const uint8_t* crossStrandForces(const HairModel& model, const SolverConfig& config,
                                 const SolverPlan& plan, const StepInputs& inputs, double s0,
                                 double h, int threads, HairState* state, StepStats* local) {
  double t0 = inputs.clock ? inputs.clock() : 0.0;
  if (plan.force_cohesion) {
    computeCohesionForces(model, config.cohesion, state);
    local->stage_particles[kStageCohesionForces] += model.particleCount();
    if (inputs.clock) {
      const double now = inputs.clock();
      local->stage_cpu_s[kStageCohesionForces] += now - t0;
      t0 = now;
    }
  } else {
    std::fill(state->external_force.begin(), state->external_force.end(), Vec3::Zero());
  }
  if (!config.hair_contact.enabled) return nullptr;
  HairContactState& contact = state->hair_contact;
  const uint64_t builds = contact.list_builds;
  const Pose head = interpolate(inputs.head_start, inputs.head_end, s0);
  local->hair_contacts =
      computeHairContactForces(model, config.hair_contact, h, plan.theta, head, threads, state);
  local->hair_contact_list_builds += contact.list_builds - builds;
  local->hair_contact_listed_pairs = contact.listed_pairs;
  local->stage_particles[kStageHairContact] += contact.sphere_particle.size();
  uint64_t strands = 0;
  for (uint8_t touching : contact.strand_touching) strands += touching;
  local->hair_contact_strands = strands;
  if (inputs.clock) local->stage_cpu_s[kStageHairContact] += inputs.clock() - t0;
  return plan.force_cohesion ? nullptr : contact.strand_touching.data();
}

/// Cross-strand forces couple the strands: substeps outside, strands inside, the forces
/// evaluated at every substep. The force-based baselines run one strand at a time (their
/// reference results); hair contact alone keeps the SIMD lanes.
void advanceCoupled(const HairModel& model, const SolverConfig& config, const SolverPlan& plan,
                    const StepInputs& inputs, int nsub, double h, int threads, HairState* state,
                    StepStats* per_thread, StepStats* local) {
  const int strands = model.simulatedStrandCount();
  for (int k = 0; k < nsub; ++k) {
    const uint8_t* external =
        crossStrandForces(model, config, plan, inputs, double(k) / nsub, h, threads, state, local);
    if (!plan.force_cohesion) {
      advanceStrands(model, config, plan, inputs, k, k + 1, nsub, h, threads, external, state,
                     per_thread);
      continue;
    }
    detail::parallelFor(threads, detail::Schedule::kDynamic, 8, strands, [&](int s) {
      const int t = detail::threadIndex();
      StrandFlags flags = strandFlags(model, config, inputs, s, *state);
      flags.external_force = true;
      StepStats& ts = per_thread[t];
      const double strain = stepBlock(1, model, config, plan, inputs, s, 1, &flags, k, k + 1, nsub,
                                      h, state, &state->scratch[t], &ts);
      ts.max_strain_before_limit = std::max(ts.max_strain_before_limit, strain);
    });
  }
}

/// Adds the run time since `since` to a stage (only with a clock); returns now.
double lapStage(const StepInputs& inputs, int stage, double since, StepStats* stats) {
  if (!inputs.clock) return 0.0;
  const double now = inputs.clock();
  stats->stage_cpu_s[stage] += now - since;
  return now;
}

}  // namespace

void step(const HairModel& model, const SolverConfig& config, const StepInputs& inputs, double dt_s,
          HairState* state, StepStats* stats) {
  StepStats local;
  const double wall_start = inputs.clock ? inputs.clock() : 0.0;
  const int nsub = substepCount(config, dt_s);
  local.substeps = nsub;
  local.substep_s = nsub > 0 ? dt_s / nsub : 0.0;
  if (nsub == 0) {
    if (stats) *stats = local;
    return;
  }
  const double h = dt_s / nsub;
  const SolverPlan plan = detail::planStep(model, config, h);
  const StepInputs in = carryHairThroughHeadJump(model, config, inputs, dt_s, state, &local);
  const int threads = std::max(
      1, std::min(config.integrator.resolvedThreads(), static_cast<int>(state->scratch.size())));
  // Per-thread counters, summed in thread order afterwards (integers and maxima: the sums do not
  // depend on which thread ran which strand). On the stack: a step allocates nothing.
  StepStats per_thread[kMaxSolverThreads];
  if (plan.force_cohesion || config.hair_contact.enabled)
    advanceCoupled(model, config, plan, in, nsub, h, threads, state, per_thread, &local);
  else
    advanceStrands(model, config, plan, in, 0, nsub, nsub, h, threads, nullptr, state, per_thread);
  for (int t = 0; t < threads; ++t) local.accumulate(per_thread[t]);
  state->warnings.nonfinite_repairs += local.nonfinite_repairs;
  state->warnings.nonfinite_values += local.nonfinite_values;
  state->warnings.strain_repairs += local.strain_repairs;
  state->warnings.rest_shape_repairs += local.rest_shape_repairs;
  double lap = in.clock ? in.clock() : 0.0;
  if (model.followers.guide_strands > 0) {
    updateFollowers(model, config, in.head_end, in.obstacles, dt_s, threads, state);
    local.stage_particles[kStageFollowers] +=
        model.particleCount() - model.strand_offsets[model.followers.guide_strands];
    lap = lapStage(in, kStageFollowers, lap, &local);
  }
  // Stable cohesion (eq. 10): display positions after the step, never fed back (A14).
  local.cohesion_particles =
      updateDisplayCohesion(model, config.cohesion, state->time_s + dt_s, state, threads);
  local.stage_particles[kStageCohesion] += local.cohesion_particles;
  lap = lapStage(in, kStageCohesion, lap, &local);
  if (in.clock) local.wall_s = lap - wall_start;
  state->time_s += dt_s;
  ++state->step_count;
  state->substep_count += nsub;
  if (stats) *stats = local;
}

}  // namespace wet_curly_hair

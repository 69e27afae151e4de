#include "wet_curly_hair/core/solver.h"

#include <algorithm>
#include <cmath>

#ifdef _OPENMP
#include <omp.h>
#endif

#include "solver_internal.h"
#include "wet_curly_hair/core/cohesion.h"
#include "wet_curly_hair/core/frames.h"
#include "wet_curly_hair/core/head_collider.h"
#include "wet_curly_hair/core/smoothing.h"
#include "wet_curly_hair/core/springs.h"
#include "wet_curly_hair/core/wet_kernels.h"

namespace wet_curly_hair {

int substepCount(const SolverConfig& config, double dt_s) {
  if (!(dt_s > 0.0)) return 0;
  return std::max(1, static_cast<int>(std::ceil(dt_s / config.integrator.substep_s - 1e-9)));
}

int dampingPassCount(const HairModel& model, const SolverConfig& config, double h) {
  const double c =
      config.stretch.damping_ns_per_m + config.bend.damping_ns_per_m + config.core.damping_ns_per_m;
  int passes = config.integrator.damping_passes;
  if (c > 0.0 && model.min_mass_kg > 0.0) {
    const double tau_max = 0.9 * model.min_mass_kg / (2.0 * c);
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
                                                  "cohesion_forces"};
  return stage >= 0 && stage < kStageCount ? kNames[stage] : "unknown";
}

void StepStats::accumulate(const StepStats& o) {
  max_strain_before_limit = std::max(max_strain_before_limit, o.max_strain_before_limit);
  strain_limited_edges += o.strain_limited_edges;
  velocity_clamps += o.velocity_clamps;
  head_contacts += o.head_contacts;
  constraint_rounds += o.constraint_rounds;
  repaired_strands += o.repaired_strands;
  curl_particle_substeps += o.curl_particle_substeps;
  adhesion_particle_substeps += o.adhesion_particle_substeps;
  adhesion_active += o.adhesion_active;
  obstacle_particle_substeps += o.obstacle_particle_substeps;
  obstacle_contacts += o.obstacle_contacts;
  cohesion_particles += o.cohesion_particles;
  wet_strands += o.wet_strands;
  strands_near_obstacles += o.strands_near_obstacles;
  for (int k = 0; k < kStageCount; ++k) {
    stage_particles[k] += o.stage_particles[k];
    stage_cpu_s[k] += o.stage_cpu_s[k];
  }
}

namespace {

/// The axial spring f = k (|e| - L) e / |e| (stretch, eq. 1; core, eq. 5 with b) linearised:
/// d f / d e = k [u u^T + (1 - L / |e|) (I - u u^T)], u = e / |e|, written as
/// isotropic + axial * u u^T. The transverse term is clamped at zero under compression so that
/// the implicit system stays positive definite (the usual definiteness fix; the exact force is
/// still applied).
struct AxialJacobian {
  Vec3 u = Vec3::Zero();  ///< unit direction (zero when degenerate)
  double isotropic = 0.0;
  double axial = 0.0;  ///< added along u u^T
};

inline AxialJacobian axialSpringJacobian(const Vec3& e, double rest, double k) {
  AxialJacobian j;
  const double len = e.norm();
  if (len < kDirectionEpsilon) return j;
  j.u = e / len;
  j.isotropic = k * std::max(0.0, 1.0 - rest / len);
  j.axial = k - j.isotropic;
  return j;
}

/// a I + b u u^T + c w w^T (symmetric).
inline Mat3 isotropicPlusDyads(double a, double b, const Vec3& u, double c, const Vec3& w) {
  Mat3 m = b * (u * u.transpose()) + c * (w * w.transpose());
  m.diagonal().array() += a;
  return m;
}

}  // namespace

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

uint64_t collideHeadParticles(const HairModel& model, const CollisionConfig& config,
                              const SubstepMotion& motion, double h, Vec3* p, Vec3* v, int n) {
  const double delta = config.offset_m;
  const double mu = config.friction;
  uint64_t contacts = 0;
  for (int i = 1; i < n; ++i) {
    const Vec3 x_head = motion.r1_inverse * (p[i] - motion.pose1.translation);
    Vec3 n_head;
    const double dist = model.head.distance(x_head, &n_head);
    if (dist >= delta) continue;
    const Vec3 v_head = (p[i] - (motion.r0 * x_head + motion.pose0.translation)) / h;
    collideParticle(dist, motion.r1 * n_head, delta, mu, v_head, &p[i], &v[i]);
    ++contacts;
  }
  return contacts;
}

uint64_t collideObstacleParticles(const Obstacles& obstacles, const ObstacleCollisionConfig& config,
                                  Vec3* p, Vec3* v, int n) {
  uint64_t contacts = 0;
  for (int i = 1; i < n; ++i) {
    Vec3 normal;
    const double dist = obstacles.distance(p[i], &normal);
    if (collideParticle(dist, normal, config.offset_m, config.friction, Vec3::Zero(), &p[i], &v[i]))
      ++contacts;
  }
  return contacts;
}

uint64_t limitStrainEdges(const StretchConfig& config, const double* rest, double h, Vec3* p,
                          Vec3* v, int n, double* max_strain) {
  const double limit = config.strain_limit;
  const bool inelastic_limit = config.limit_velocity == "inelastic";
  uint64_t projected = 0;
  for (int i = 0; i + 1 < n; ++i) {
    const double len = (p[i + 1] - p[i]).norm();
    *max_strain = std::max(*max_strain, len / rest[i] - 1.0);
    const Vec3 disp = limitEdgeLength(p[i], p[i + 1], (1.0 + limit) * rest[i]);
    if (disp.squaredNorm() > 0.0) {
      p[i + 1] += disp;
      if (inelastic_limit) {
        // Remove the edge's stretching relative velocity only: never adds energy, even when a
        // collider keeps pushing the particle back out every substep.
        const Vec3 e = (p[i + 1] - p[i]).normalized();
        const double a = (v[i + 1] - v[i]).dot(e);
        if (a > 0.0) v[i + 1] -= a * e;
      } else {
        v[i + 1] += disp / h;  // Selle 2008: the projection as a velocity impulse
      }
      ++projected;
    }
  }
  return projected;
}

uint64_t extraConstraintRounds(const HairModel& model, const SolverConfig& config,
                               const Obstacles* obstacles, bool obstacle_collision,
                               const SubstepMotion& motion, const double* rest, double h,
                               uint64_t touched, uint64_t projected, Vec3* p, Vec3* v, int n) {
  // Only where something touched and the limit then moved a particle: only that can have pulled
  // a projected particle back in (hair resting on the scalp, within the limit, needs none).
  // Project again and limit again until nothing is inside or nothing moves (or the rounds run
  // out). The strain limit runs last, so the edge bound holds exactly and what remains is a
  // penetration smaller than the last round's.
  const bool head_stage = config.collision.head_enabled;
  uint64_t rounds = 0;
  for (int round = 0; touched > 0 && projected > 0 && round < config.collision.constraint_rounds;
       ++round) {
    touched =
        (head_stage ? collideHeadParticles(model, config.collision, motion, h, p, v, n) : 0) +
        (obstacle_collision ? collideObstacleParticles(*obstacles, config.obstacle, p, v, n) : 0);
    if (touched == 0) break;
    double unused = 0.0;
    projected = limitStrainEdges(config.stretch, rest, h, p, v, n, &unused);
    ++rounds;
  }
  return rounds;
}

void updateCurlRotation(const HairModel& model, const CurlConfig& config, int strand,
                        const Vec3& root, const Vec3& tip, double h, HairState* state) {
  const Vec3 axis = tip - root;
  const double len = axis.norm();
  // A8: when the strand curls back onto its root the axis is undefined: keep the last M.
  if (!(len > 1e-3 * model.strand_length_m[strand])) return;
  const Mat3 target_rotation = helixToHairRotation(model.helix_axis[strand], axis / len);
  const double tc = config.rotation_time_constant_s;
  if (tc <= 0.0) {
    state->curl_rotation[strand] = target_rotation;
  } else {
    const Quat from(state->curl_rotation[strand]), to(target_rotation);
    state->curl_rotation[strand] =
        from.slerp(1.0 - std::exp(-h / tc), to).normalized().toRotationMatrix();
  }
}

int blockStrands(const HairModel& model, int first_strand, int width) {
  const int count = std::min(width, model.strandCount() - first_strand);
  if (count < 1) return 0;
  const int n = model.strandSize(first_strand);
  if (n < 2) return 0;
  for (int l = 1; l < count; ++l)
    if (model.strandSize(first_strand + l) != n) return 0;
  return count;
}

}  // namespace detail

using detail::stiffnessActive;

void prepareStrandStep(const HairModel& model, const SolverConfig& config, int strand,
                       const StrandFlags& flags, double h, const HairState& state,
                       StrandScratch* scratch) {
  if (!stiffnessActive(config, flags)) return;
  const StiffnessConfig& st = config.stiffness;
  const int begin = model.strandBegin(strand);
  const double dry =
      stiffnessFactor(st.global_factor, st.wet_factor, st.dry_factor, 0.0, h, st.reference_step_s);
  for (int i = 0; i < model.strandSize(strand); ++i) {
    const double sigma = state.saturation[begin + i];
    scratch->velocity_factor[i] =
        sigma > 0.0 ? stiffnessFactor(st.global_factor, st.wet_factor, st.dry_factor, sigma, h,
                                      st.reference_step_s)
                    : dry;
  }
}

double substepStrand(const HairModel& model, const SolverConfig& config, const StepInputs& inputs,
                     int strand, const StrandFlags& flags, double s0, double s1, double h,
                     HairState* state, StrandScratch* scratch, StepStats* stats) {
  detail::StageLaps laps(inputs.clock, stats);
  const int begin = model.strandBegin(strand);
  const int n = model.strandSize(strand);
  const int edges = n - 1;
  Vec3* p = &state->position[begin];
  Vec3* v = &state->velocity[begin];
  const double* sigma = &state->saturation[begin];
  const double* inv_m = &model.inv_mass[begin];
  const double* m = &model.mass_kg[begin];
  const double* rest = &model.rest_edge_m[begin];
  StrandScratch& scr = *scratch;
  Vec3* f = scr.force.data();
  Vec3* d = scr.smooth_bend.data();
  Vec3* b = scr.smooth_core.data();
  Vec3* nu = scr.smooth_vel.data();
  Mat3* frame = scr.frame.data();
  Vec3* target = scr.target.data();
  const double theta = integratorTheta(config.integrator);
  const bool implicit = theta > 0.0;

  // 1. Root: carried rigidly by the head, interpolated at this substep (§9.2 step 1). Its
  // velocity is the one that lands it exactly on the pose at the end of the substep.
  const detail::SubstepMotion motion = detail::substepMotion(inputs, s0, s1, h);
  const Pose& pose0 = motion.pose0;
  const Pose& pose1 = motion.pose1;
  const Vec3 root_next = pose1.apply(model.rest_position_head[begin]);
  v[0] = (root_next - p[0]) / h;
  // The head's rigid motion over this substep (world frame, about its origin).
  const Vec3& omega = motion.omega;
  const Vec3& head_velocity = motion.head_velocity;

  // 2. Smoothed curves, frames parallel-transported along the alpha_b curve, bend targets.
  const Mat3 root_frame = motion.r0 * model.root_frame_head[strand];
  smoothDifferences(p, n, model.beta_bend[strand], d);
  transportFrames(root_frame, d, edges, frame);
  for (int i = 0; i < edges; ++i) target[i] = frame[i] * model.bend_local_target[begin + i];
  smoothDifferences(p, n, model.beta_core[strand], b);
  laps.lap(kStageFrames, n);

  // 3. Elastic forces and gravity; segment convention F_i += f, F_{i+1} -= f (A1).
  const Vec3 g = config.gravity_m_s2;
  for (int i = 0; i < n; ++i) f[i] = m[i] * g;
  if (flags.external_force)
    for (int i = 0; i < n; ++i) f[i] += state->external_force[begin + i];
  const double ks = config.stretch.stiffness_n_per_m;
  const double kb = config.bend.stiffness_n_per_m;
  const double kc = config.core.stiffness_n_per_m;
  for (int i = 0; i < edges; ++i) {
    const Vec3 e = p[i + 1] - p[i];
    const Vec3 fs = stretchForce(e, rest[i], ks) + bendForce(e, target[i], kb) +
                    coreForce(b[i], model.core_rest_m[begin + i], kc);
    f[i] += fs;
    f[i + 1] -= fs;
  }
  laps.lap(kStageForces, n);
  // Curl exaggeration (eqs. 6-9, A6-A10), wet strands only: the strand's helix edges turned by
  // M (helix root-to-tip onto the hair's, A7), pulled on with the saturation of the edge.
  const bool curl_stage = flags.wet && config.curl.enabled && config.curl.weight_n_per_m > 0.0;
  const bool curl_spring = config.curl.mode == "spring";
  if (curl_stage) {
    detail::updateCurlRotation(model, config.curl, strand, p[0], p[n - 1], h, state);
    const Mat3& rot = state->curl_rotation[strand];
    for (int i = 0; i < edges; ++i) {
      const double s = 0.5 * (sigma[i] + sigma[i + 1]);
      if (s <= 0.0) continue;
      const Vec3 u = curlForce(rot * model.helix_edge[begin + i], p[i + 1] - p[i],
                               config.curl.weight_n_per_m, s, curl_spring);
      f[i + 1] += u;
      f[i] -= u;
    }
    stats->curl_particle_substeps += n;
    laps.lap(kStageCurl, n);
  }
  // Adhesion (eqs. 11-12, A15-A16): wet particles between h/2 and h from an obstacle surface are
  // pulled toward it, with peak acceleration sigma * peak at 3h/4.
  const Obstacles* obstacles = inputs.obstacles;
  const bool obstacle_stage = flags.near_obstacle && obstacles && !obstacles->empty();
  if (obstacle_stage && flags.wet && config.adhesion.enabled &&
      config.adhesion.peak_acceleration_m_s2 > 0.0) {
    const double hk = config.adhesion.radius_m;
    const bool literal = config.adhesion.literal_polynomial;
    const double scale = config.adhesion.peak_acceleration_m_s2 / adhesionKernelPeak(hk, literal);
    uint64_t evaluated = 0;
    for (int i = 1; i < n; ++i) {
      if (sigma[i] <= 0.0) continue;
      ++evaluated;
      Vec3 normal;
      const double dist = obstacles->distance(p[i], &normal);
      const double a = adhesionKernel(dist, hk, literal);
      if (a <= 0.0) continue;
      f[i] -= (sigma[i] * m[i] * scale * a) * normal;
      ++stats->adhesion_active;
    }
    stats->adhesion_particle_substeps += evaluated;
    laps.lap(kStageAdhesion, evaluated);
  }

  const double cs = config.stretch.damping_ns_per_m;
  const double cb = config.bend.damping_ns_per_m;
  const double cc = config.core.damping_ns_per_m;
  // The perpendicular relative velocity of eq. (4) is measured in the frame turning with the
  // head: a strand co-rotating rigidly with the head has dv = omega x e, which the literal term
  // would drag on, bending steadily spinning hair by c_b omega / k_b (measured: 0.6 % of the
  // strand length at 0.25 rev/s). Subtracting omega x e makes the damping vanish on rigid
  // co-rotation and leaves it unchanged on a still head.
  Vec3* v_start = scr.velocity_start.data();
  if (!implicit || n < 2) {
    // 4. Velocity update (semi-implicit Euler), roots excluded.
    for (int i = 1; i < n; ++i) v[i] += (h * inv_m[i]) * f[i];
    // 5. Damping passes with tau = h / n_d (eq. 1, 4, 5 damping terms; §9.2 step 5).
    const int passes = dampingPassCount(model, config, h);
    const double tau = h / passes;
    for (int pass = 0; pass < passes; ++pass) {
      if (cc > 0.0) smoothDifferences(v, n, model.beta_core[strand], nu);
      for (int i = 0; i < n; ++i) f[i].setZero();
      for (int i = 0; i < edges; ++i) {
        const Vec3 e = p[i + 1] - p[i];
        const Vec3 dv = v[i + 1] - v[i];
        Vec3 fd = stretchDampingForce(e, dv, cs) + bendDampingForce(e, dv - omega.cross(e), cb);
        if (cc > 0.0) fd += coreDampingForce(b[i], nu[i], cc);
        f[i] += fd;
        f[i + 1] -= fd;
      }
      for (int i = 1; i < n; ++i) v[i] += (tau * inv_m[i]) * f[i];
    }
  } else {
    // 4-5 implicit: a theta method on the velocity u that moves the particles,
    // x+ = x + h u, v+ = v + (u - v) / theta, with the forces linearised about the start of the
    // substep: M (u - v) = theta h [f(x) + theta h K u + D(u)], D the damping (linear in the
    // velocities; the core's, which acts on IIR-smoothed velocities, is taken at v and
    // corrected by its local part). Per edge e = (i, i+1) the coupling block is
    // G = theta h (C + theta h J) with J = d f_e / d e and C = d f_damp / d dv, so that
    //   (m_i + G_{i-1} + G_i) u_i - G_{i-1} u_{i-1} - G_i u_{i+1} = m_i v_i + theta h f_i,
    // a block-tridiagonal system solved root to tip (block Thomas), the root's u prescribed.
    const double th = theta * h;
    const double local_core = std::pow(1.0 - model.beta_core[strand], 2);  // d b_i / d e_i
    const double kw = curl_stage && curl_spring ? config.curl.weight_n_per_m : 0.0;
    if (cc > 0.0) smoothDifferences(v, n, model.beta_core[strand], nu);
    Mat3* block = scr.edge_block.data();
    for (int i = 0; i < edges; ++i) {
      const Vec3 e = p[i + 1] - p[i];
      const Vec3 dv = v[i + 1] - v[i];
      // G = theta h (C + theta h J) = alpha I + beta u u^T + gamma w w^T, u along the edge, w
      // along the core difference b_i: stretch (k_s, c_s along u), bend (k_b I, c_b across u),
      // core (k_c and c_c along w, local part), curl spring (k_w sigma I).
      const AxialJacobian stretch = axialSpringJacobian(e, rest[i], ks);
      const AxialJacobian core =
          axialSpringJacobian(b[i], model.core_rest_m[begin + i], kc * local_core);
      const double curl = kw > 0.0 ? kw * 0.5 * (sigma[i] + sigma[i + 1]) : 0.0;
      const double has_axis = stretch.u.squaredNorm() > 0.0 ? 1.0 : 0.0;
      const double alpha = th * (cb + th * (stretch.isotropic + core.isotropic + kb + curl));
      const double beta = th * (has_axis * (cs - cb) + th * stretch.axial);
      const double gamma = th * (cc * local_core + th * core.axial);
      block[i] = isotropicPlusDyads(alpha, beta, stretch.u, gamma, core.u);
      // Explicit remainders: the co-rotation part of the bend damping (constant in u; omega x e is
      // already across the edge) and the non-local part of the core damping.
      Vec3 fe = -cb * omega.cross(e);
      if (cc > 0.0)
        fe += coreDampingForce(b[i], nu[i], cc) - (cc * local_core * core.u.dot(dv)) * core.u;
      f[i] += fe;
      f[i + 1] -= fe;
    }
    Vec3* rhs = scr.rhs.data();
    Mat3* pivot_inverse = scr.pivot_inverse.data();
    for (int i = 0; i < n; ++i) v_start[i] = v[i];
    for (int i = 1; i < n; ++i) rhs[i] = m[i] * v[i] + th * f[i];
    rhs[1] += block[0] * v[0];  // the prescribed root velocity moved to the right-hand side
    // Forward elimination.
    for (int i = 1; i < n; ++i) {
      Mat3 pivot = block[i - 1];
      pivot.diagonal().array() += m[i];
      if (i < edges) pivot += block[i];
      if (i > 1) {
        const Mat3 w = block[i - 1] * pivot_inverse[i - 1];
        pivot -= w * block[i - 1];
        rhs[i] += w * rhs[i - 1];
      }
      pivot_inverse[i] = pivot.inverse();
    }
    // Back substitution: u into v.
    v[n - 1] = pivot_inverse[n - 1] * rhs[n - 1];
    for (int i = n - 2; i >= 1; --i) v[i] = pivot_inverse[i] * (rhs[i] + block[i] * v[i + 1]);
    const double inv_theta = 1.0 / theta;
    for (int i = 1; i < n; ++i) v[i] = v_start[i] + inv_theta * (v[i] - v_start[i]);
  }
  // Velocity clamp root -> tip (Iben §2.2a): at most strain_rate_limit of strain per substep.
  // Explicit only: it keeps the explicit stretch spring stable. Applied to v+ of a theta method
  // it breaks the scheme's consistency (v+ = v + (u - v) / theta rings in stiff modes, the clamp
  // cuts one sign of it): measured, midpoint at 1e-3 s on the built-in scene reached strain
  // 13.6 before limiting with the clamp and 0.035 without. The implicit solve holds the stretch.
  const double rate = config.stretch.strain_rate_limit_per_substep / h;
  for (int i = 0; i < (implicit ? 0 : edges); ++i) {
    const Vec3 vnew = clampAxialRelativeVelocity(p[i + 1] - p[i], v[i], v[i + 1], rate * rest[i]);
    if (vnew != v[i + 1]) {
      v[i + 1] = vnew;
      ++stats->velocity_clamps;
    }
  }

  // 6. Stiffness, eq. (13) (A17): v <- (xi zeta_i)^(h / h_ref) v, on the velocity relative to the
  // head's rigid motion (or the absolute velocity, literal option).
  const StiffnessConfig& st = config.stiffness;
  if (stiffnessActive(config, flags)) {
    const double* factor = scr.velocity_factor.data();  // prepareStrandStep()
    for (int i = 1; i < n; ++i) {
      const double k = factor[i];
      if (st.relative_to_head) {
        const Vec3 carried = head_velocity + omega.cross(p[i] - pose0.translation);
        v[i] = carried + k * (v[i] - carried);
      } else {
        v[i] *= k;
      }
    }
  }

  // 8. Position update: with the new velocity (explicit), with the theta-weighted one (implicit,
  // equal to the solved u unless the clamp or eq. 13 changed v+).
  p[0] = root_next;
  if (!implicit) {
    for (int i = 1; i < n; ++i) p[i] += h * v[i];
  } else {
    for (int i = 1; i < n; ++i) p[i] += h * ((1.0 - theta) * v_start[i] + theta * v[i]);
  }
  laps.lap(kStageIntegrate, n);

  // 7. Head collision (§6) and external obstacles (static in the world, their own offset and
  // friction), then 9. strain limiting root -> tip with velocity correction (Selle 2008, §2.2b).
  const bool head_stage = config.collision.head_enabled;
  const bool obstacle_collision = obstacle_stage && config.obstacle.enabled;
  uint64_t touched = 0;
  if (head_stage) {
    const uint64_t contacts =
        detail::collideHeadParticles(model, config.collision, motion, h, p, v, n);
    stats->head_contacts += contacts;
    touched += contacts;
    laps.lap(kStageHeadCollision, n - 1);
  }
  if (obstacle_collision) {
    const uint64_t contacts =
        detail::collideObstacleParticles(*obstacles, config.obstacle, p, v, n);
    stats->obstacle_contacts += contacts;
    stats->obstacle_particle_substeps += n - 1;
    touched += contacts;
    laps.lap(kStageObstacleCollision, n - 1);
  }
  double max_strain = 0.0;
  const uint64_t projected =
      detail::limitStrainEdges(config.stretch, rest, h, p, v, n, &max_strain);
  stats->strain_limited_edges += projected;
  stats->constraint_rounds += detail::extraConstraintRounds(
      model, config, obstacles, obstacle_collision, motion, rest, h, touched, projected, p, v, n);
  laps.lap(kStageStrainLimit, n - 1);
  return max_strain;
}

namespace {

int ompThreadIndex() {
#ifdef _OPENMP
  return omp_get_thread_num();
#else
  return 0;
#endif
}

/// True when every position and velocity of the strand is finite; counts non-finite scalars.
bool strandFinite(const HairModel& model, int s, const HairState& state, uint64_t* nonfinite) {
  const int begin = model.strandBegin(s);
  const int n = model.strandSize(s);
  bool ok = true;
  for (int i = begin; i < begin + n; ++i) {
    for (int k = 0; k < 3; ++k) {
      if (!std::isfinite(state.position[i][k])) ++*nonfinite, ok = false;
      if (!std::isfinite(state.velocity[i][k])) ++*nonfinite, ok = false;
    }
  }
  return ok;
}

bool strandStrainOk(const HairModel& model, const SolverConfig& config, int s,
                    const HairState& state) {
  const int begin = model.strandBegin(s);
  const int n = model.strandSize(s);
  const double bound = 3.0 * config.stretch.strain_limit;
  for (int i = begin; i + 1 < begin + n; ++i) {
    const double len = (state.position[i + 1] - state.position[i]).norm();
    if (len > (1.0 + bound) * model.rest_edge_m[i]) return false;
  }
  return true;
}

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

/// Restores strand s to its last good state, carried from the start pose to the end pose.
void repairStrand(const HairModel& model, const StepInputs& inputs, int s, HairState* state) {
  const int begin = model.strandBegin(s);
  const int n = model.strandSize(s);
  const Pose& now = inputs.head_end;
  const Pose& before = inputs.head_start;
  for (int i = begin; i < begin + n; ++i) {
    const Vec3 x_head = before.applyInverse(state->last_good_position[i]);
    state->position[i] = now.apply(x_head);
    state->velocity[i] = now.rotate(before.rotation.conjugate() * state->last_good_velocity[i]);
    state->last_good_position[i] = state->position[i];
    state->last_good_velocity[i] = state->velocity[i];
  }
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
  const int strands = model.strandCount();
  // A head that jumps (faster than any head moves: a teleport, a tracking glitch) carries the
  // hair rigidly with it first; the step then sees a still head. Velocities turn with the head.
  StepInputs jumped = inputs;
  {
    const IntegratorConfig& ic = config.integrator;
    const double travel = (inputs.head_end.translation - inputs.head_start.translation).norm();
    const double turn =
        Eigen::AngleAxisd(inputs.head_end.rotation * inputs.head_start.rotation.conjugate())
            .angle();
    if ((ic.teleport_speed_m_s > 0.0 && travel > ic.teleport_speed_m_s * dt_s) ||
        (ic.teleport_angle_rad > 0.0 && turn > ic.teleport_angle_rad)) {
      const Pose jump = inputs.head_end * inputs.head_start.inverse();
      for (int i = 0; i < model.particleCount(); ++i) {
        state->position[i] = jump.apply(state->position[i]);
        state->velocity[i] = jump.rotation * state->velocity[i];
        state->last_good_position[i] = jump.apply(state->last_good_position[i]);
        state->last_good_velocity[i] = jump.rotation * state->last_good_velocity[i];
      }
      for (int s = 0; s < strands; ++s)
        state->curl_rotation[s] = jump.rotation.toRotationMatrix() * state->curl_rotation[s];
      jumped.head_start = inputs.head_end;
      local.head_jumps = 1;
      ++state->warnings.head_jumps;
    }
  }
  const StepInputs& in_ = jumped;
  const int threads =
      std::max(1, std::min(config.integrator.threads, static_cast<int>(state->scratch.size())));
  // Per-thread counters, summed in thread order afterwards (integers and maxima: the sums do not
  // depend on which thread ran which strand). On the stack: a step allocates nothing.
  StepStats per_thread[kMaxSolverThreads];
  const bool force_cohesion = config.cohesion.mode == "lin" || config.cohesion.mode == "kim";
  if (force_cohesion) {
    // The force-based baselines couple strands: substeps outside, strands inside, the
    // cross-strand forces evaluated at every substep.
    for (int k = 0; k < nsub; ++k) {
      const double t0 = in_.clock ? in_.clock() : 0.0;
      computeCohesionForces(model, config.cohesion, state);
      local.stage_particles[kStageCohesionForces] += model.particleCount();
      if (in_.clock) local.stage_cpu_s[kStageCohesionForces] += in_.clock() - t0;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 8)
      for (int s = 0; s < strands; ++s) {
        const int t = ompThreadIndex();
        StrandFlags flags = strandFlags(model, config, in_, s, *state);
        flags.external_force = true;
        StepStats& ts = per_thread[t];
        prepareStrandStep(model, config, s, flags, h, *state, &state->scratch[t]);
        const double strain =
            substepStrand(model, config, in_, s, flags, double(k) / nsub, double(k + 1) / nsub, h,
                          state, &state->scratch[t], &ts);
        ts.max_strain_before_limit = std::max(ts.max_strain_before_limit, strain);
      }
    }
  } else {
    // Strands couple only through per-step outputs: each strand runs all its substeps at once,
    // while its particles stay in cache; strands are shared among the threads. Blocks of
    // IntegratorConfig::laneWidth() strands of equal size run in SIMD lanes (the blocks are fixed
    // by strand index, so the result does not depend on the thread count).
    auto advanceStrand = [&](int s, StepStats& ts, StrandScratch* scratch) {
      const StrandFlags flags = strandFlags(model, config, in_, s, *state);
      ts.wet_strands += flags.wet;
      ts.strands_near_obstacles += flags.near_obstacle;
      prepareStrandStep(model, config, s, flags, h, *state, scratch);
      for (int k = 0; k < nsub; ++k) {
        const double strain = substepStrand(model, config, in_, s, flags, double(k) / nsub,
                                            double(k + 1) / nsub, h, state, scratch, &ts);
        ts.max_strain_before_limit = std::max(ts.max_strain_before_limit, strain);
      }
    };
    const bool lanes = config.integrator.strand_lanes;
    if (lanes) {
      const int kLanes = config.integrator.laneWidth();
      const int blocks = (strands + kLanes - 1) / kLanes;
      // One block per grab: with 16 strands per block, 100 strands are 7 blocks, and chunks of
      // two left one thread four blocks against three.
#pragma omp parallel for num_threads(threads) schedule(dynamic, 1)
      for (int blk = 0; blk < blocks; ++blk) {
        const int t = ompThreadIndex();
        StepStats& ts = per_thread[t];
        const int first = blk * kLanes;
        // A lone strand (or a block of unequal sizes) runs on its own; a partial last block of
        // two or more in lanes, so that the strand count need not be a multiple of the width.
        const int active = detail::blockStrands(model, first, kLanes);
        if (active < 2) {
          for (int s = first; s < std::min(strands, first + kLanes); ++s)
            advanceStrand(s, ts, &state->scratch[t]);
          continue;
        }
        StrandFlags flags[detail::kMaxStrandLanes];
        for (int l = 0; l < active; ++l) {
          flags[l] = strandFlags(model, config, in_, first + l, *state);
          ts.wet_strands += flags[l].wet;
          ts.strands_near_obstacles += flags[l].near_obstacle;
        }
        std::fill(flags + active, flags + kLanes, flags[active - 1]);  // the padding lanes
        const double strain = detail::stepStrandBlock(model, config, in_, first, active, flags,
                                                      nsub, h, state, &state->scratch[t], &ts);
        ts.max_strain_before_limit = std::max(ts.max_strain_before_limit, strain);
      }
    } else {
#pragma omp parallel for num_threads(threads) schedule(dynamic, 8)
      for (int s = 0; s < strands; ++s) {
        const int t = ompThreadIndex();
        advanceStrand(s, per_thread[t], &state->scratch[t]);
      }
    }
  }
  for (int t = 0; t < threads; ++t) local.accumulate(per_thread[t]);
  // Detect, repair and count numerical trouble, strand by strand (style.md §11).
  const double repair_start = in_.clock ? in_.clock() : 0.0;
  for (int s = 0; s < strands; ++s) {
    uint64_t nonfinite = 0;
    const bool finite = strandFinite(model, s, *state, &nonfinite);
    const bool strain_ok = finite && strandStrainOk(model, config, s, *state);
    const int begin = model.strandBegin(s);
    const int n = model.strandSize(s);
    if (finite && strain_ok) {
      std::copy_n(&state->position[begin], n, &state->last_good_position[begin]);
      std::copy_n(&state->velocity[begin], n, &state->last_good_velocity[begin]);
      continue;
    }
    repairStrand(model, in_, s, state);
    ++local.repaired_strands;
    if (!finite) {
      ++state->warnings.nonfinite_repairs;
      state->warnings.nonfinite_values += nonfinite;
    } else {
      ++state->warnings.strain_repairs;
    }
  }
  local.stage_particles[kStageRepair] += model.particleCount();
  const double cohesion_start = in_.clock ? in_.clock() : 0.0;
  if (in_.clock) local.stage_cpu_s[kStageRepair] += cohesion_start - repair_start;
  // Stable cohesion (eq. 10): display positions after the step, never fed back (A14).
  local.cohesion_particles = computeDisplayCohesion(model, config.cohesion, state, threads);
  local.stage_particles[kStageCohesion] += local.cohesion_particles;
  if (in_.clock) {
    const double now = in_.clock();
    local.stage_cpu_s[kStageCohesion] += now - cohesion_start;
    local.wall_s = now - wall_start;
  }
  state->time_s += dt_s;
  ++state->step_count;
  state->substep_count += nsub;
  if (stats) *stats = local;
}

}  // namespace wet_curly_hair

#include "wet_curly_hair/core/model.h"

#include <cmath>
#include <cstdio>
#include <utility>

#include "wet_curly_hair/core/cohesion_grid.h"
#include "wet_curly_hair/core/frames.h"
#include "wet_curly_hair/core/sag_free.h"
#include "wet_curly_hair/core/smoothing.h"
#include "wet_curly_hair/core/wet_kernels.h"

namespace wet_curly_hair {

bool HeadShape::validate(const std::string& p, std::string* why) const {
  using namespace config_check;
  if (!finiteVec(p + "center_m", ellipsoid.center_m, why) ||
      !positive(p + "radii_m.x", ellipsoid.radii_m.x(), why) ||
      !positive(p + "radii_m.y", ellipsoid.radii_m.y(), why) ||
      !positive(p + "radii_m.z", ellipsoid.radii_m.z(), why))
    return false;
  for (size_t i = 0; i < capsules.size(); ++i) {
    const std::string c = p + "capsules[" + std::to_string(i) + "].";
    if (!finiteVec(c + "a_m", capsules[i].a_m, why) ||
        !finiteVec(c + "b_m", capsules[i].b_m, why) ||
        !positive(c + "radius_m", capsules[i].radius_m, why))
      return false;
  }
  return true;
}

bool buildModel(const Groom& groom, double linear_density_kg_per_m, const HeadShape& head,
                const SolverConfig& config, HairModel* model, std::string* why) {
  if (!groom.validate(why)) return false;
  if (!config.validate("solver.", why)) return false;
  if (!head.validate("head.", why)) return false;
  if (!config_check::finiteInRange("groom.linear_density_kg_per_m", linear_density_kg_per_m, 1e-9,
                                   1e3, why))
    return false;
  // The springs must hold the hanging strand within the strain limit: the root edge carries the
  // weight of the whole strand, and the stretch and bend springs both act along it (the bend
  // spring of eq. 4 compares whole vectors, docs/physics.md §2.6). Past the limit the limiter
  // fights the springs on every substep and pumps energy into long strands (measured: a
  // 128-particle strand at 5 % reached 358 m/s still hanging). Per length the root edge's
  // strain is rho g l / (EA + B / alpha_b^2): physical values only, the same at any resolution.
  const double g = config.gravity_m_s2.norm();
  const double axial = config.stretch.axial_stiffness_n +
                       (config.bend.smoothing_length_m > 0.0
                            ? config.bend.stiffness_n_m2 /
                                  (config.bend.smoothing_length_m * config.bend.smoothing_length_m)
                            : 0.0);
  for (int s = 0; s < groom.strandCount() && g > 0.0; ++s) {
    double length = 0.0;
    for (uint32_t k = groom.strand_offsets[s]; k + 1 < groom.strand_offsets[s + 1]; ++k)
      length += (groom.points[k + 1] - groom.points[k]).norm();
    const double strain = linear_density_kg_per_m * g * length / axial;
    if (strain > config.stretch.strain_limit) {
      if (why) {
        *why = "solver.stretch.axial_stiffness_n: " +
               std::to_string(config.stretch.axial_stiffness_n) + " N (with B / alpha_b^2 " +
               std::to_string(axial - config.stretch.axial_stiffness_n) + " N) lets strand " +
               std::to_string(s) + " (" + std::to_string(length) + " m) hang at strain " +
               std::to_string(strain) + " under its own weight, past solver.stretch.strain_limit " +
               std::to_string(config.stretch.strain_limit) +
               " (stiffen the stretch spring or lighten groom.linear_density_kg_per_m)";
      }
      return false;
    }
  }
  HairModel built;
  buildModelUnchecked(groom, linear_density_kg_per_m, head, config, &built, true);
  if (!checkExplicitSubstep(built, config, why)) return false;
  *model = std::move(built);
  return true;
}

bool checkExplicitSubstep(const HairModel& model, const SolverConfig& config, std::string* why) {
  const double bound = model.explicit_substep_bound_s;
  if (config.integrator.method != "explicit" || bound <= 0.0 ||
      config.integrator.substep_s <= bound)
    return true;
  if (why) {
    char text[400];
    std::snprintf(text, sizeof text,
                  "solver.integrator.substep_s: %.3g s is past the explicit integrator's stability "
                  "bound for this groom, %.3g s (%.1f of 2 / omega_max on its stiffest particle; "
                  "the bound shrinks with the edge length); set at most %.3g s, or use an "
                  "implicit integrator (solver.integrator.method: midpoint, the default)",
                  config.integrator.substep_s, bound, kExplicitStabilityFraction, bound);
    *why = text;
  }
  return false;
}

Vec3List makeHelix(int count, double edge_m, double radius_m, double pitch_m) {
  Vec3List h(count);
  if (radius_m <= 0.0) {
    for (int k = 0; k < count; ++k) h[k] = Vec3(0.0, 0.0, k * edge_m);
    return h;
  }
  const double dt = helixAngleStepForChord(radius_m, pitch_m, edge_m);
  for (int k = 0; k < count; ++k) h[k] = helixPoint(radius_m, pitch_m, k * dt);
  return h;
}

namespace {

/// Rest edges and lumped masses (rho (L_{i-1} + L_i) / 2) of strand s, from the groom's edges.
/// Returns its mean edge.
double strandMasses(const Vec3* p, int begin, int size, double rho, HairModel* m) {
  double total = 0.0;
  for (int i = 0; i + 1 < size; ++i) {
    const double l = (p[i + 1] - p[i]).norm();
    m->rest_edge_m[begin + i] = l;
    m->length_share_m[begin + i] += 0.5 * l;
    m->length_share_m[begin + i + 1] += 0.5 * l;
    total += l;
  }
  for (int i = 0; i < size; ++i) {
    m->mass_kg[begin + i] = rho * m->length_share_m[begin + i];
    m->inv_mass[begin + i] = i == 0 ? 0.0 : 1.0 / m->mass_kg[begin + i];  // the root: kinematic
  }
  return total / (size - 1);
}

/// alpha_b for a strand of mean edge l: the configured length, lengthened to the flutter bound
/// kMinBendSmoothingEdges edges with `stabilize` (config.h).
double bendSmoothingLength(const BendConfig& bend, double l, bool stabilize) {
  return stabilize ? std::max(bend.smoothing_length_m, kMinBendSmoothingEdges * l)
                   : bend.smoothing_length_m;
}

/// The spring constants of strand s from the per-length parameters (docs/physics.md §2.11): per
/// edge the stretch spring over the groom's edge, per strand bend, core and curl over the mean
/// edge l; with `stabilize`, c_b raised to the flutter bound. Returns whether alpha_b or c_b
/// was raised.
bool strandSpringConstants(const SolverConfig& c, int s, bool stabilize, HairModel* m) {
  const int begin = m->strandBegin(s), size = m->strandSize(s);
  const Vec3* p = &m->rest_position_head[begin];
  for (int i = 0; i + 1 < size; ++i) {
    const double l = (p[i + 1] - p[i]).norm();
    m->stretch_k[begin + i] = c.stretch.axial_stiffness_n / l;
    m->stretch_c[begin + i] = c.stretch.damping_n_s / l;
  }
  const double l = m->mean_edge_m[s];
  const double alpha_b = bendSmoothingLength(c.bend, l, stabilize);
  bool raised = alpha_b != c.bend.smoothing_length_m;
  // B / (l alpha^2): the edge's angle to its target is alpha kappa for a curvature change kappa
  // smooth on the alpha scale, so sum 1/2 k_b (l alpha kappa)^2 = integral 1/2 B kappa^2 ds.
  const double alpha2 = std::max(alpha_b * alpha_b, l * l);
  m->bend_k[s] = c.bend.stiffness_n_m2 / (l * alpha2);
  m->bend_c[s] = c.bend.damping_n_s / l;
  const double critical = 2.0 * std::sqrt(m->bend_k[s] * m->linear_density_kg_per_m * l);
  if (stabilize && m->bend_k[s] > 0.0 && m->bend_c[s] < kMinBendDampingRatio * critical) {
    m->bend_c[s] = kMinBendDampingRatio * critical;
    raised = true;
  }
  m->core_k[s] = c.core.stiffness_n / l;
  m->core_c[s] = c.core.damping_n_s / l;
  m->curl_k[s] = c.curl.weight_n / l;
  return raised && c.bend.stiffness_n_m2 > 0.0;
}

/// The explicit substep bound and the damping-pass bound of strand s (HairModel fields), folded
/// into the model's. On the dry masses: water held by the hair (water.h, applyWaterMass) only
/// makes particles heavier, and heavier particles only loosen both bounds.
void strandStabilityBounds(int s, HairModel* m) {
  const int begin = m->strandBegin(s), n = m->strandSize(s);
  auto dryInvMass = [&](int k) {
    return 1.0 / (m->linear_density_kg_per_m * m->length_share_m[k]);
  };
  const double shared = m->bend_k[s] + m->core_k[s] + m->curl_k[s];
  const double shared_c = m->bend_c[s] + m->core_c[s];
  double lambda = 0.0, damping = m->max_damping_per_mass;
  for (int i = 1; i < n; ++i) {
    const double k_in = m->stretch_k[begin + i - 1] + shared;
    const double k_out = i + 1 < n ? m->stretch_k[begin + i] + shared : 0.0;
    lambda = std::max(lambda, 2.0 * (k_in + k_out) * dryInvMass(begin + i));
    const double c_in = m->stretch_c[begin + i - 1] + shared_c;
    const double c_out = i + 1 < n ? m->stretch_c[begin + i] + shared_c : 0.0;
    damping = std::max(damping, std::max(c_in, c_out) * dryInvMass(begin + i));
  }
  m->max_damping_per_mass = damping;
  if (lambda > 0.0) {
    const double bound = kExplicitStabilityFraction * 2.0 / std::sqrt(lambda);
    if (m->explicit_substep_bound_s <= 0.0 || bound < m->explicit_substep_bound_s)
      m->explicit_substep_bound_s = bound;
  }
}

void allSpringConstants(const SolverConfig& config, bool stabilize, HairModel* m) {
  const int strands = m->strandCount();
  for (auto* v : {&m->bend_k, &m->bend_c, &m->core_k, &m->core_c, &m->curl_k})
    v->assign(strands, 0.0);
  m->stretch_k.assign(m->particleCount(), 0.0);
  m->stretch_c.assign(m->particleCount(), 0.0);
  m->bend_stabilized_strands = 0;
  m->explicit_substep_bound_s = 0.0;
  m->max_damping_per_mass = 0.0;
  for (int s = 0; s < strands; ++s) {
    m->bend_stabilized_strands += strandSpringConstants(config, s, stabilize, m);
    strandStabilityBounds(s, m);
  }
}

}  // namespace

bool updateSpringConstants(const SolverConfig& config, HairModel* model, std::string* why) {
  if (!config.validate("solver.", why)) return false;
  HairModel updated = *model;
  allSpringConstants(config, true, &updated);
  if (!checkExplicitSubstep(updated, config, why)) return false;
  layModelLanes(config.integrator, &updated);  // in the layout the new config asks for
  *model = std::move(updated);
  return true;
}

void buildModelUnchecked(const Groom& groom, double rho, const HeadShape& head,
                         const SolverConfig& config, HairModel* model, bool stabilize_bending) {
  HairModel m;
  m.strand_offsets = groom.strand_offsets;
  m.rest_position_head = groom.points;
  m.head = head;
  m.linear_density_kg_per_m = rho;
  const int n = groom.particleCount();
  const int strands = groom.strandCount();
  m.mass_kg.assign(n, 0.0);
  m.inv_mass.assign(n, 0.0);
  m.length_share_m.assign(n, 0.0);
  m.rest_head_distance_m.assign(n, 0.0);
  for (int k = 0; k < n; ++k) {
    Vec3 normal;
    m.rest_head_distance_m[k] = head.distance(groom.points[k], &normal);
  }
  m.rest_edge_m.assign(n, 0.0);
  m.stretch_k.assign(n, 0.0);
  m.stretch_c.assign(n, 0.0);
  m.bend_local_target.assign(n, Vec3::Zero());
  m.core_rest_m.assign(n, 0.0);
  m.mean_edge_m.assign(strands, 0.0);
  m.beta_bend.assign(strands, 1.0);
  m.beta_core.assign(strands, 1.0);
  m.strand_length_m.assign(strands, 0.0);
  m.root_frame_head.assign(strands, Mat3::Identity());
  m.helix_edge.assign(n, Vec3::Zero());
  m.helix_axis.assign(strands, Vec3::UnitZ());

  Vec3List d, b;
  Mat3List frames;
  for (int s = 0; s < strands; ++s) {
    const int begin = m.strandBegin(s);
    const int size = m.strandSize(s);
    m.max_strand_size = std::max(m.max_strand_size, size);
    const Vec3* p = &groom.points[begin];
    const double l = strandMasses(p, begin, size, rho, &m);
    m.mean_edge_m[s] = l;
    m.strand_length_m[s] = l * (size - 1);
    // beta from the rest mean edge, once, for the rest and the current curves (A3, §10.3).
    m.beta_bend[s] = smoothingBeta(l, bendSmoothingLength(config.bend, l, stabilize_bending));
    m.beta_core[s] = smoothingBeta(l, config.core.smoothing_length_m);
    // Root frame: tangent along the rest root edge (= d_0, so edge 0 is aligned at rest),
    // second axis toward the scalp normal's perpendicular part.
    const Vec3 e0 = p[1] - p[0];
    m.root_frame_head[s] = frameFromTangent(e0, groom.root_normals[s].cross(e0).norm() > 1e-6
                                                    ? groom.root_normals[s]
                                                    : anyPerpendicular(e0.normalized()));
    d.resize(size - 1);
    b.resize(size - 1);
    frames.resize(size - 1);
    smoothDifferences(p, size, m.beta_bend[s], d.data());
    transportFrames(m.root_frame_head[s], d.data(), size - 1, frames.data());
    smoothDifferences(p, size, m.beta_core[s], b.data());
    for (int i = 0; i + 1 < size; ++i) {
      m.bend_local_target[begin + i] = frames[i].transpose() * (p[i + 1] - p[i]);
      m.core_rest_m[begin + i] = b[i].norm();
    }
    // The strand's own helix (A9), turned about its axis to the phase that best matches the rest
    // pose once aligned (the twist about the root-to-tip axis is otherwise undetermined, A8).
    const Vec3List helix =
        makeHelix(size, l, config.curl.helix_radius_m, config.curl.helix_pitch_m);
    const Vec3 rest_axis = p[size - 1] - p[0];
    Vec3 axis = (helix[size - 1] - helix[0]).normalized();
    double phase = 0.0;
    if (rest_axis.norm() > 1e-9 && config.curl.helix_radius_m > 0.0) {
      const Mat3 to_rest = helixToHairRotation(axis, rest_axis.normalized());
      double a = 0.0, c = 0.0;
      for (int i = 0; i + 1 < size; ++i) {
        const Vec3 h = helix[i + 1] - helix[i];
        const Vec3 q = to_rest.transpose() * (p[i + 1] - p[i]);
        a += h.x() * q.x() + h.y() * q.y();
        c += h.x() * q.y() - h.y() * q.x();
      }
      phase = std::atan2(c, a);
    }
    const Mat3 turn = Eigen::AngleAxisd(phase, Vec3::UnitZ()).toRotationMatrix();
    for (int i = 0; i + 1 < size; ++i) m.helix_edge[begin + i] = turn * (helix[i + 1] - helix[i]);
    axis = (turn * (helix[size - 1] - helix[0])).normalized();
    m.helix_axis[s] = axis;
  }
  allSpringConstants(config, stabilize_bending, &m);
  // Sag-free start (docs/physics.md §8): the head starts at identity orientation in every scene
  // (headPose(motion, 0) = motion.base, not a scene parameter), so gravity in the head frame is
  // the world gravity.
  if (config.sag_free) makeSagFree(config, config.gravity_m_s2, &m);
  if (config.cohesion.evaluation == "grid" && config.cohesion.grid_wet_sums == "auto") {
    m.cohesion_rest_density_cells = config.cohesion.grid_cells_per_radius;
    m.cohesion_rest_particles_per_cell =
        restParticlesPerCell(m, config.cohesion.radius_m, m.cohesion_rest_density_cells);
  }
  m.cohesion_grid_nodes = cohesionGridNodeBound(m, config);
  layModelLanes(config.integrator, &m);
  *model = std::move(m);
}

}  // namespace wet_curly_hair

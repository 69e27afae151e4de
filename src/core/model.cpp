#include "wet_curly_hair/core/model.h"

#include <cmath>

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

bool buildModel(const Groom& groom, double particle_mass_kg, const HeadShape& head,
                const SolverConfig& config, HairModel* model, std::string* why) {
  if (!groom.validate(why)) return false;
  if (!config.validate("solver.", why)) return false;
  if (!head.validate("head.", why)) return false;
  if (!config_check::positive("groom.particle_mass_kg", particle_mass_kg, why)) return false;
  const double kb = config.bend.stiffness_n_per_m;
  if (kb > 0.0) {
    const double ratio = config.bend.damping_ns_per_m / (2.0 * std::sqrt(kb * particle_mass_kg));
    if (ratio < kMinBendDampingRatio) {
      if (why) {
        *why = "solver.bend.damping_ns_per_m: " + std::to_string(config.bend.damping_ns_per_m) +
               " N s/m is " + std::to_string(ratio) +
               " of critical for k_b = " + std::to_string(kb) + " N/m and " +
               std::to_string(particle_mass_kg) + " kg particles; below " +
               std::to_string(kMinBendDampingRatio) +
               " the bending spring flutters (raise the damping or lower k_b)";
      }
      return false;
    }
  }
  // The springs must hold the hanging strand within the strain limit: the root edge carries the
  // weight of the whole strand, and the stretch and bend springs both act along it (the bend
  // spring of eq. 4 compares whole vectors, docs/physics.md §2.6). Past the limit the limiter
  // fights the springs on every substep and pumps energy into long strands (measured: a
  // 128-particle strand at 5 % reached 358 m/s still hanging).
  const double axial_k = config.stretch.stiffness_n_per_m + config.bend.stiffness_n_per_m;
  const double g = config.gravity_m_s2.norm();
  for (int s = 0; s < groom.strandCount() && g > 0.0; ++s) {
    const int begin = static_cast<int>(groom.strand_offsets[s]);
    const double edge = (groom.points[begin + 1] - groom.points[begin]).norm();
    const double weight = (groom.strandSize(s) - 1) * particle_mass_kg * g;
    const double strain = weight / (axial_k * edge);
    if (strain > config.stretch.strain_limit) {
      if (why) {
        *why = "solver.stretch.stiffness_n_per_m: " +
               std::to_string(config.stretch.stiffness_n_per_m) + " N/m (with k_b " +
               std::to_string(config.bend.stiffness_n_per_m) + ") lets strand " +
               std::to_string(s) + " hang at strain " + std::to_string(strain) +
               " under its own weight, past solver.stretch.strain_limit " +
               std::to_string(config.stretch.strain_limit) +
               " (stiffen the springs, lighten groom.particle_mass_kg, or use fewer particles)";
      }
      return false;
    }
  }
  buildModelUnchecked(groom, particle_mass_kg, head, config, model);
  return true;
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

void buildModelUnchecked(const Groom& groom, double particle_mass_kg, const HeadShape& head,
                         const SolverConfig& config, HairModel* model) {
  HairModel m;
  m.strand_offsets = groom.strand_offsets;
  m.rest_position_head = groom.points;
  m.head = head;
  const int n = groom.particleCount();
  const int strands = groom.strandCount();
  m.mass_kg.assign(n, particle_mass_kg);
  m.inv_mass.assign(n, 1.0 / particle_mass_kg);
  m.min_mass_kg = particle_mass_kg;
  m.rest_edge_m.assign(n, 0.0);
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
    m.inv_mass[begin] = 0.0;  // the root is kinematic
    const Vec3* p = &groom.points[begin];
    double total = 0.0;
    for (int i = 0; i + 1 < size; ++i) {
      m.rest_edge_m[begin + i] = (p[i + 1] - p[i]).norm();
      total += m.rest_edge_m[begin + i];
    }
    const double l = total / (size - 1);
    m.mean_edge_m[s] = l;
    m.strand_length_m[s] = total;
    // beta from the rest mean edge, once, for the rest and the current curves (A3, §10.3).
    m.beta_bend[s] = smoothingBeta(l, config.bend.smoothing_edges * l);
    m.beta_core[s] = smoothingBeta(l, config.core.smoothing_edges * l);
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
  // Sag-free start (docs/physics.md §8): the head starts at identity orientation in every scene
  // (headPose(motion, 0) = motion.base, not a scene parameter), so gravity in the head frame is
  // the world gravity.
  if (config.sag_free) makeSagFree(config, config.gravity_m_s2, &m);
  m.cohesion_grid_nodes = cohesionGridNodeBound(m, config);
  *model = std::move(m);
}

}  // namespace wet_curly_hair

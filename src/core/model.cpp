#include "wet_curly_hair/core/model.h"

#include <cmath>

#include "wet_curly_hair/core/frames.h"
#include "wet_curly_hair/core/smoothing.h"

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
    if (!finiteVec(c + "a_m", capsules[i].a_m, why) || !finiteVec(c + "b_m", capsules[i].b_m, why) ||
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
               " N s/m is " + std::to_string(ratio) + " of critical for k_b = " +
               std::to_string(kb) + " N/m and " + std::to_string(particle_mass_kg) +
               " kg particles; below " + std::to_string(kMinBendDampingRatio) +
               " the bending spring flutters (raise the damping or lower k_b)";
      }
      return false;
    }
  }
  buildModelUnchecked(groom, particle_mass_kg, head, config, model);
  return true;
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
  }
  *model = std::move(m);
}

}  // namespace wet_curly_hair

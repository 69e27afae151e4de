#include "wet_curly_hair/core/hair_contact.h"

#include <algorithm>
#include <cmath>

#include "parallel.h"
#include "wet_curly_hair/core/cohesion.h"

namespace wet_curly_hair {

using detail::parallelFor;
using detail::Schedule;

HairContactPair hairContactPair(const Vec3& d, const Vec3& dv, double contact_m, double k, double c,
                                double friction, double m_eff, double h) {
  HairContactPair out;
  const double r2 = d.squaredNorm();
  if (!(r2 < contact_m * contact_m) || r2 <= 0.0) return out;
  const double r = std::sqrt(r2);
  const Vec3 n = d / r;
  out.normal = n;
  const double vn = dv.dot(n);
  // Normal push: penalty plus damping of the approach; a separating pair is slowed by the
  // damping but never pulled together.
  out.push = std::max(0.0, k * (contact_m - r) - c * vn);
  out.force = -out.push * n;
  if (!(out.push > 0.0)) return out;
  out.stiffness = k, out.damping = c;
  const Vec3 dv_t = dv - vn * n;
  const double slide = dv_t.norm();
  if (slide > 0.0 && friction > 0.0) {
    // Kinetic friction drags i along j's sliding; capped at what stops the sliding of the pair
    // in one substep (the discrete form of sticking).
    const double drag = std::min(friction * out.push, m_eff * slide / h);
    out.force += (drag / slide) * dv_t;
    out.friction_damping = std::min(friction * out.push / slide, 100.0 * m_eff / h);
  }
  return out;
}

double hairContactEngagement(double a, bool touching, double h, double ramp_s, double taper_s) {
  if (touching) return ramp_s > 0.0 ? std::min(1.0, a + h / ramp_s) : 1.0;
  return taper_s > 0.0 ? std::max(0.0, a - h / taper_s) : 0.0;
}

double hairContactEnergy(const HairModel& model, const HairContactConfig& config,
                         HairState* state) {
  HairContactState* c = &state->hair_contact;
  prepareHairContact(model, config, c);
  const int spheres = static_cast<int>(c->sphere_particle.size());
  if (spheres == 0) return 0.0;
  for (int a = 0; a < spheres; ++a) c->sphere_position[a] = state->position[c->sphere_particle[a]];
  const double contact = 2.0 * config.radius_m;
  // The grid is scratch: the pair list is independent of it (each build fills it anew).
  buildNeighborGrid(c->sphere_position, contact, &c->grid, 1);
  double twice = 0.0;  // every pair is met from both spheres
  for (int a = 0; a < spheres; ++a) {
    if (!c->sphere_position[a].allFinite()) continue;
    forEachOtherStrandNeighbor(c->grid, c->sphere_position, c->grid.strand_of[a],
                               c->sphere_position[a], contact, [&](uint32_t b, double) {
                                 const double k = std::min(c->engagement[a], c->engagement[b]) *
                                                  config.stiffness_n_per_m3 *
                                                  c->sphere_length_m[a] * c->sphere_length_m[b];
                                 twice += hairContactPairEnergy(
                                     c->sphere_position[b] - c->sphere_position[a], contact, k);
                               });
  }
  return 0.5 * twice;
}

void prepareHairContact(const HairModel& model, const HairContactConfig& config,
                        HairContactState* c) {
  if (c->particles == model.particleCount() && c->radius_m == config.radius_m &&
      c->sparsity == config.sparsity)
    return;
  c->particles = model.particleCount();
  c->radius_m = config.radius_m;
  c->sparsity = config.sparsity;
  c->sphere_particle.clear();
  c->sphere_length_m.clear();
  c->sphere_offsets.assign(1, 0);
  // Iben's pruning: from the root, the next sphere is the first particle at least s 2 r from the
  // last one (rest pose); a pruned particle's share of the strand goes to the sphere before it.
  const double spacing = config.sparsity * 2.0 * config.radius_m;
  // The simulated strands only: followers are placed from their guides after the step.
  for (int s = 0; s < model.simulatedStrandCount(); ++s) {
    const int begin = model.strandBegin(s), end = begin + model.strandSize(s);
    int last = begin;
    c->sphere_particle.push_back(static_cast<uint32_t>(begin));
    c->sphere_length_m.push_back(model.length_share_m[begin]);
    for (int i = begin + 1; i < end; ++i) {
      if ((model.rest_position_head[i] - model.rest_position_head[last]).norm() >= spacing) {
        last = i;
        c->sphere_particle.push_back(static_cast<uint32_t>(i));
        c->sphere_length_m.push_back(0.0);
      }
      c->sphere_length_m.back() += model.length_share_m[i];
    }
    c->sphere_offsets.push_back(static_cast<uint32_t>(c->sphere_particle.size()));
  }
  const size_t spheres = c->sphere_particle.size();
  c->engagement.assign(spheres, 0.0);
  c->touching.assign(spheres, 0);
  c->sphere_position.assign(spheres, Vec3::Zero());
  c->built_position.assign(spheres, Vec3::Zero());
  c->neighbor_start.assign(spheres + 1, 0);
  c->strand_touching.assign(model.strandCount(), 0);              // followers: never touching
  c->external_block.assign(model.particleCount(), Mat3::Zero());  // only spheres' are written
  c->grid.resize(static_cast<int>(spheres), c->sphere_offsets);
  c->list_valid = false;
}

namespace {

/// Most list entries per sphere (on average over a build range's spheres): a groom far denser
/// than its contact radius (thousands of neighbours within reach) would otherwise fill memory.
/// Past it the substep has no contact forces and the overflow is counted
/// (WarningStats::hair_contact_overflows).
constexpr size_t kMaxListedPerSphere = 256;

/// Ranges the list build cuts the spheres into (fixed, so that nothing depends on the threads).
constexpr int kListChunks = 16;

/// True when two spheres may have come within 2 r that were farther than 2 r + skin when the
/// list was built: the two largest displacements since then add up to more than the skin.
/// Measured in the head frame: a rigid motion keeps every distance, so hair carried by the head
/// keeps its list.
bool listStale(const HairContactState& c, const Pose& head, double skin_m) {
  if (!c.list_valid) return true;
  const Mat3 to_head = head.rotation.conjugate().toRotationMatrix();
  double first = 0.0, second = 0.0;
  for (size_t a = 0; a < c.sphere_position.size(); ++a) {
    const double moved =
        (to_head * (c.sphere_position[a] - head.translation) - c.built_position[a]).norm();
    if (!(moved <= skin_m)) return true;  // also NaN
    if (moved > first) {
      second = first;
      first = moved;
    } else if (moved > second) {
      second = moved;
    }
  }
  return first + second > skin_m;
}

/// The Verlet list: every pair of spheres of different strands within 2 r + skin, in both
/// directions, each row sorted. One pass: the spheres are cut into kListChunks contiguous ranges,
/// each filled into its own buffer by whichever thread takes it, and the buffers are joined in
/// sphere order (the same list, and the same overflow decision, for any thread count).
bool buildPairList(const HairContactConfig& config, const Pose& head, int threads,
                   HairContactState* c) {
  const double reach = 2.0 * config.radius_m + config.skin_m;
  const int spheres = static_cast<int>(c->sphere_position.size());
  buildNeighborGrid(c->sphere_position, reach, &c->grid, threads);
  const int chunks = kListChunks;
  if (static_cast<int>(c->chunk_rows.size()) < chunks) c->chunk_rows.resize(chunks);
  parallelFor(threads, Schedule::kStatic, 1, chunks, [&](int t) {
    std::vector<uint32_t>& out = c->chunk_rows[t];
    out.clear();
    const int lo = int(int64_t(spheres) * t / chunks),
              hi = int(int64_t(spheres) * (t + 1) / chunks);
    const size_t cap = kMaxListedPerSphere * static_cast<size_t>(hi - lo);
    for (int a = lo; a < hi; ++a) {
      const size_t first = out.size();
      if (c->sphere_position[a].allFinite() && out.size() <= cap)
        forEachOtherStrandNeighbor(c->grid, c->sphere_position, c->grid.strand_of[a],
                                   c->sphere_position[a], reach,
                                   [&](uint32_t b, double) { out.push_back(b); });
      std::sort(out.begin() + first, out.end());
      c->neighbor_start[a + 1] = static_cast<uint32_t>(out.size() - first);
    }
  });
  for (int t = 0; t < chunks; ++t) {
    const int lo = int(int64_t(spheres) * t / chunks),
              hi = int(int64_t(spheres) * (t + 1) / chunks);
    if (c->chunk_rows[t].size() > kMaxListedPerSphere * static_cast<size_t>(hi - lo)) {
      c->list_valid = false;  // too dense for the radius: no list, no forces (counted)
      for (std::vector<uint32_t>& rows : c->chunk_rows) std::vector<uint32_t>().swap(rows);
      return false;
    }
  }
  for (int a = 0; a < spheres; ++a) c->neighbor_start[a + 1] += c->neighbor_start[a];
  if (c->neighbor.size() < c->neighbor_start[spheres])
    c->neighbor.resize(c->neighbor_start[spheres]);
  parallelFor(threads, Schedule::kStatic, 1, chunks, [&](int t) {
    const int lo = int(int64_t(spheres) * t / chunks);
    std::copy(c->chunk_rows[t].begin(), c->chunk_rows[t].end(),
              c->neighbor.begin() + c->neighbor_start[lo]);
  });
  const Mat3 to_head = head.rotation.conjugate().toRotationMatrix();
  for (int a = 0; a < spheres; ++a)
    c->built_position[a] = to_head * (c->sphere_position[a] - head.translation);
  c->list_valid = true;
  c->listed_pairs = c->neighbor_start[spheres] / 2;
  ++c->list_builds;
  return true;
}

/// The direction between two spheres exactly on top of each other (strands that start
/// coincident), where d = 0 gives none: across the lower-indexed sphere's strand, perpendicular
/// to its edge there, signed by the index order so that the pair's forces stay exactly opposite.
/// Returned as a tiny d = x_b - x_a for the pair law.
Vec3 coincidentOffset(const HairModel& model, const HairState& state, const HairContactState& c,
                      uint32_t a, uint32_t b) {
  const uint32_t low = std::min(a, b);
  const int p = static_cast<int>(c.sphere_particle[low]);
  const int strand = static_cast<int>(c.grid.strand_of[low]);
  const int end = model.strandBegin(strand) + model.strandSize(strand);
  const Vec3 edge = p + 1 < end ? Vec3(state.position[p + 1] - state.position[p])
                                : Vec3(state.position[p] - state.position[p - 1]);
  Vec3 axis = Vec3::Zero();  // the coordinate axis least along the edge
  int k = 0;
  edge.cwiseAbs().minCoeff(&k);
  axis[k] = 1.0;
  Vec3 across = edge.cross(axis);
  across = across.norm() > 0.0 ? Vec3(across.normalized()) : Vec3::UnitX();
  return (a == low ? 1e-12 : -1e-12) * across;
}

}  // namespace

uint64_t computeHairContactForces(const HairModel& model, const HairContactConfig& config, double h,
                                  double implicit_theta, const Pose& head, int threads,
                                  HairState* state) {
  HairContactState* c = &state->hair_contact;
  prepareHairContact(model, config, c);
  const int spheres = static_cast<int>(c->sphere_particle.size());
  for (int a = 0; a < spheres; ++a) c->sphere_position[a] = state->position[c->sphere_particle[a]];
  if (listStale(*c, head, config.skin_m) && !buildPairList(config, head, threads, c)) {
    ++state->warnings.hair_contact_overflows;
    std::fill(c->touching.begin(), c->touching.end(), 0);
    std::fill(c->strand_touching.begin(), c->strand_touching.end(), 0);
    for (uint32_t p : c->sphere_particle) c->external_block[p] = Mat3::Zero();
    c->touching_pairs = c->active_spheres = c->listed_pairs = 0;
    return 0;
  }
  const double contact = 2.0 * config.radius_m;
  const double K = config.stiffness_n_per_m3, D = config.damping_n_s_per_m3;
  const double theta = implicit_theta;
  const bool implicit = theta > 0.0;
  // Each sphere sums its own pairs in list order: no two threads write one particle, and the
  // pair force on b is exactly minus the one on a, so momentum is conserved pair by pair.
  const int64_t pairs = detail::parallelSum(threads, 64, spheres, [&](int a) {
    const uint32_t pa = c->sphere_particle[a];
    const Vec3& xa = c->sphere_position[a];
    const Vec3& va = state->velocity[pa];
    Vec3 f = Vec3::Zero();
    // Implicit methods: the sums of k n n^T, of c n n^T + c_t P and of k n n^T v_j.
    Mat3 stiffness = Mat3::Zero(), damping = Mat3::Zero();
    Vec3 partner_pull = Vec3::Zero();
    int64_t touching = 0;
    for (uint32_t e = c->neighbor_start[a]; e < c->neighbor_start[a + 1]; ++e) {
      const uint32_t b = c->neighbor[e];
      const uint32_t pb = c->sphere_particle[b];
      Vec3 d = c->sphere_position[b] - xa;
      if (!(d.squaredNorm() < contact * contact)) continue;
      if (d.squaredNorm() == 0.0) d = coincidentOffset(model, *state, *c, a, b);
      ++touching;
      const double inv = model.inv_mass[pa] + model.inv_mass[pb];
      if (!(inv > 0.0)) continue;  // two roots: both kinematic
      const double share = c->sphere_length_m[a] * c->sphere_length_m[b];
      const double ramp = std::min(c->engagement[a], c->engagement[b]);
      const Vec3& vb = state->velocity[pb];
      const HairContactPair pair = hairContactPair(d, vb - va, contact, ramp * K * share, D * share,
                                                   config.friction, 1.0 / inv, h);
      if (!implicit) {
        f += pair.force;
        continue;
      }
      // Friction as the viscous drag c_t P (v_j - v_i): its start value is kinetic friction
      // uncapped (the implicit drag cannot reverse the sliding, so it needs no cap).
      const Mat3 nn = pair.normal * pair.normal.transpose();
      const Mat3 tangential = pair.friction_damping * (Mat3::Identity() - nn);
      f += -pair.push * pair.normal + tangential * (vb - va);
      stiffness += pair.stiffness * nn;
      damping += pair.damping * nn + tangential;
      // The pair's centre-of-mass velocity (the partner's own when it is a kinematic root).
      const Vec3 pair_velocity = (model.inv_mass[pb] * va + model.inv_mass[pa] * vb) / inv;
      partner_pull += pair.stiffness * (nn * pair_velocity);
    }
    c->touching[a] = touching > 0;
    if (implicit) {
      // Backward Euler in this sphere's own position and velocity, the other sphere moving on at
      // its start velocity (docs/hair_contact.md): the push at x_i + h u_i against
      // x_j + h v_j, the damping and friction on the end velocity v+ = v + (u - v) / theta. In
      // the theta method's M (u - v) = theta h f this adds theta h^2 K + h C to the particle's
      // diagonal and theta h^2 K v_j + h C v_i to the right-hand side, here h K v_j + C v_i /
      // theta in the force. Stable for any stiffness of a pair (their relative velocity is
      // multiplied by (1 - b) / (1 + b) per substep, b = h c / m); the theta-weighted form (K at
      // x + theta h u, C on u) would multiply it by (1 - 3 a) / (1 + a), a = theta h c / m, which
      // passes -1 from a = 1 (a stiff midpoint contact rings).
      c->external_block[pa] = (theta * h * h) * stiffness + h * damping;
      f += h * partner_pull + (damping * va) / theta;
    }
    state->external_force[pa] += f;
    return touching;
  });
  for (int a = 0; a < spheres; ++a)
    c->engagement[a] = hairContactEngagement(c->engagement[a], c->touching[a] != 0, h,
                                             config.ramp_time_s, config.taper_time_s);
  uint64_t active = 0;
  for (int s = 0; s < model.simulatedStrandCount(); ++s) {
    uint8_t any = 0;
    for (uint32_t a = c->sphere_offsets[s]; a < c->sphere_offsets[s + 1]; ++a)
      any |= c->touching[a];
    c->strand_touching[s] = any;
    for (uint32_t a = c->sphere_offsets[s]; a < c->sphere_offsets[s + 1]; ++a)
      active += c->touching[a];
  }
  c->active_spheres = active;
  c->touching_pairs = static_cast<uint64_t>(pairs / 2);
  return c->touching_pairs;
}

}  // namespace wet_curly_hair

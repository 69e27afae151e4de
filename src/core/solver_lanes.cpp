// The substep (explicit or implicit) on a block of kStrandLanes strands at once, one strand per
// SIMD lane (issue 6, part 4). The recurrences of a strand run root to tip (IIR smoothing, frame
// transport, the block-Thomas solve, the strain limit), so they cannot be vectorised along the
// strand; across strands they are the same operations on independent data. The block's particles
// are gathered into a structure of arrays once per step, stay in cache through all its substeps
// (strands couple only through per-step outputs) and are scattered back at the end.
//
// Every stage mirrors substepStrand() in solver.cpp operation for operation (the comments there
// give the equations); the rare branches (a degenerate frame, a half-turn rotation, a particle
// at the centre of a head shape) and the stages that read the obstacle field, which is not laid
// out for lanes, run the scalar code on the lanes that need it. The result agrees with the scalar
// path to round-off (test_solver_lanes) and, like it, does not depend on the thread count: the
// blocks are fixed by strand index.
#include <algorithm>
#include <cmath>

#ifdef __AVX__
#include <immintrin.h>
#endif

#include "solver_internal.h"
#include "wet_curly_hair/core/frames.h"
#include "wet_curly_hair/core/head_collider.h"
#include "wet_curly_hair/core/smoothing.h"
#include "wet_curly_hair/core/springs.h"
#include "wet_curly_hair/core/wet_kernels.h"

namespace wet_curly_hair {
namespace detail {
namespace {

static_assert(kStrandLanes == 4, "the lane type below holds 4 doubles");
typedef double D4 __attribute__((vector_size(32)));     // one double per strand
typedef long long M4 __attribute__((vector_size(32)));  // lane masks: -1 true, 0 false

inline D4 splat(double x) { return D4{x, x, x, x}; }
inline D4 vsqrt(D4 x) {
#ifdef __AVX__
  return _mm256_sqrt_pd(x);
#else
  return D4{std::sqrt(x[0]), std::sqrt(x[1]), std::sqrt(x[2]), std::sqrt(x[3])};
#endif
}
/// std::max(a, b) lane by lane, including its answer for NaN (a unless a < b).
inline D4 vmax(D4 a, D4 b) { return a < b ? b : a; }
inline D4 vmin(D4 a, D4 b) { return b < a ? b : a; }
inline bool any(M4 m) { return (m[0] | m[1] | m[2] | m[3]) != 0; }
inline M4 laneMask(const bool* on) {
  return M4{on[0] ? -1LL : 0LL, on[1] ? -1LL : 0LL, on[2] ? -1LL : 0LL, on[3] ? -1LL : 0LL};
}

struct V3L {
  D4 x, y, z;
};
inline V3L operator+(const V3L& a, const V3L& b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
inline V3L operator-(const V3L& a, const V3L& b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
inline V3L operator*(D4 s, const V3L& a) { return {s * a.x, s * a.y, s * a.z}; }
inline V3L operator/(const V3L& a, D4 s) { return {a.x / s, a.y / s, a.z / s}; }
inline V3L& operator+=(V3L& a, const V3L& b) { return a = a + b; }
inline V3L& operator-=(V3L& a, const V3L& b) { return a = a - b; }
inline D4 dot(const V3L& a, const V3L& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
inline V3L cross(const V3L& a, const V3L& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline V3L select(M4 m, const V3L& a, const V3L& b) {
  return {m ? a.x : b.x, m ? a.y : b.y, m ? a.z : b.z};
}
inline V3L splat(const Vec3& a) { return {splat(a.x()), splat(a.y()), splat(a.z())}; }
inline V3L zero3() { return splat(Vec3::Zero()); }
inline Vec3 lane(const V3L& a, int l) { return Vec3(a.x[l], a.y[l], a.z[l]); }
inline void setLane(V3L* a, int l, const Vec3& v) {
  a->x[l] = v.x();
  a->y[l] = v.y();
  a->z[l] = v.z();
}

/// Row-major 3x3, one matrix per lane.
struct M3L {
  D4 m[3][3];
};
inline V3L operator*(const M3L& a, const V3L& v) {
  return {a.m[0][0] * v.x + a.m[0][1] * v.y + a.m[0][2] * v.z,
          a.m[1][0] * v.x + a.m[1][1] * v.y + a.m[1][2] * v.z,
          a.m[2][0] * v.x + a.m[2][1] * v.y + a.m[2][2] * v.z};
}
inline M3L operator*(const M3L& a, const M3L& b) {
  M3L r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      r.m[i][j] = a.m[i][0] * b.m[0][j] + a.m[i][1] * b.m[1][j] + a.m[i][2] * b.m[2][j];
  return r;
}
inline M3L splat(const Mat3& a) {
  M3L r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = splat(a(i, j));
  return r;
}
inline Mat3 lane(const M3L& a, int l) {
  Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r(i, j) = a.m[i][j][l];
  return r;
}
inline void setLane(M3L* a, int l, const Mat3& v) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) a->m[i][j][l] = v(i, j);
}
inline V3L column(const M3L& a, int j) { return {a.m[0][j], a.m[1][j], a.m[2][j]}; }
inline M3L select(M4 mask, const M3L& a, const M3L& b) {
  M3L r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = mask ? a.m[i][j] : b.m[i][j];
  return r;
}
/// The inverse by cofactors (as Eigen's 3x3 inverse).
inline M3L inverse(const M3L& a) {
  const D4(&m)[3][3] = a.m;
  const D4 c00 = m[1][1] * m[2][2] - m[1][2] * m[2][1];
  const D4 c10 = m[1][2] * m[2][0] - m[1][0] * m[2][2];
  const D4 c20 = m[1][0] * m[2][1] - m[1][1] * m[2][0];
  const D4 inv_det = splat(1.0) / (c00 * m[0][0] + c10 * m[0][1] + c20 * m[0][2]);
  M3L r;
  r.m[0][0] = c00 * inv_det;
  r.m[1][0] = c10 * inv_det;
  r.m[2][0] = c20 * inv_det;
  r.m[0][1] = (m[2][1] * m[0][2] - m[2][2] * m[0][1]) * inv_det;
  r.m[1][1] = (m[2][2] * m[0][0] - m[2][0] * m[0][2]) * inv_det;
  r.m[2][1] = (m[2][0] * m[0][1] - m[2][1] * m[0][0]) * inv_det;
  r.m[0][2] = (m[0][1] * m[1][2] - m[0][2] * m[1][1]) * inv_det;
  r.m[1][2] = (m[0][2] * m[1][0] - m[0][0] * m[1][2]) * inv_det;
  r.m[2][2] = (m[0][0] * m[1][1] - m[0][1] * m[1][0]) * inv_det;
  return r;
}
/// a I + b u u^T + c w w^T.
inline M3L isotropicPlusDyads(D4 a, D4 b, const V3L& u, D4 c, const V3L& w) {
  const D4 uu[3] = {u.x, u.y, u.z};
  const D4 ww[3] = {w.x, w.y, w.z};
  M3L r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = b * (uu[i] * uu[j]) + c * (ww[i] * ww[j]);
  for (int i = 0; i < 3; ++i) r.m[i][i] += a;
  return r;
}
inline M3L operator+(const M3L& a, const M3L& b) {
  M3L r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[i][j] + b.m[i][j];
  return r;
}
inline M3L operator-(const M3L& a, const M3L& b) {
  M3L r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[i][j] - b.m[i][j];
  return r;
}

/// The block's structure of arrays, carved from the thread's StrandScratch::lane_buffer.
struct LaneArrays {
  V3L *p, *v, *f, *d, *b, *nu, *v_start, *rhs, *target, *local_target, *helix_edge;
  M3L *block, *pivot_inverse;
  D4 *m, *inv_m, *rest, *core_rest, *sigma, *factor;
  // Obstacle distance cache: where each particle's distance was last evaluated, and by how much
  // it then exceeded the reach of the obstacle stages (negative: evaluate next time).
  V3L* obstacle_anchor;
  D4* obstacle_slack;
};

LaneArrays carve(StrandScratch* scratch) {
  double* base = scratch->lane_buffer.data();
  // 32-byte alignment for the vector loads.
  base += (32 - reinterpret_cast<uintptr_t>(base) % 32) % 32 / sizeof(double);
  const int n = scratch->lane_capacity;
  LaneArrays a;
  auto v3 = [&]() {
    V3L* r = reinterpret_cast<V3L*>(base);
    base += 12 * n;
    return r;
  };
  auto m3 = [&]() {
    M3L* r = reinterpret_cast<M3L*>(base);
    base += 36 * n;
    return r;
  };
  auto d4 = [&]() {
    D4* r = reinterpret_cast<D4*>(base);
    base += 4 * n;
    return r;
  };
  a.p = v3(), a.v = v3(), a.f = v3(), a.d = v3(), a.b = v3(), a.nu = v3(), a.v_start = v3();
  a.rhs = v3(), a.target = v3(), a.local_target = v3(), a.helix_edge = v3();
  a.block = m3(), a.pivot_inverse = m3();
  a.m = d4(), a.inv_m = d4(), a.rest = d4(), a.core_rest = d4(), a.sigma = d4(), a.factor = d4();
  a.obstacle_anchor = v3();
  a.obstacle_slack = d4();
  return a;
}

/// I + [v]_x + [v]_x^2 / (1 + c), v = from x to (minimalRotation's small-angle form).
inline M3L rodrigues(const V3L& from, const V3L& to, D4 c) {
  const V3L v = cross(from, to);
  const D4 zero = splat(0.0);
  M3L vx;
  vx.m[0][0] = zero, vx.m[0][1] = -v.z, vx.m[0][2] = v.y;
  vx.m[1][0] = v.z, vx.m[1][1] = zero, vx.m[1][2] = -v.x;
  vx.m[2][0] = -v.y, vx.m[2][1] = v.x, vx.m[2][2] = zero;
  const M3L vx2 = vx * vx;
  const D4 s = splat(1.0) + c;
  M3L r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = vx.m[i][j] + vx2.m[i][j] / s;
  for (int i = 0; i < 3; ++i) r.m[i][i] = splat(1.0) + r.m[i][i];
  return r;
}

/// frameFromTangent(f.col(0), f.col(1)) on every lane; the lanes whose hint is parallel to the
/// tangent (the rare branch) are redone by the scalar function.
inline M3L orthonormalizeLanes(const M3L& f) {
  V3L t = column(f, 0);
  t = t / vsqrt(dot(t, t));
  const V3L hint = column(f, 1);
  V3L n = hint - dot(hint, t) * t;
  const D4 n_len = vsqrt(dot(n, n));
  n = n / n_len;
  const V3L b = cross(t, n);
  M3L r;
  r.m[0][0] = t.x, r.m[1][0] = t.y, r.m[2][0] = t.z;
  r.m[0][1] = n.x, r.m[1][1] = n.y, r.m[2][1] = n.z;
  r.m[0][2] = b.x, r.m[1][2] = b.y, r.m[2][2] = b.z;
  const M4 rare = n_len < splat(1e-9);
  if (any(rare))
    for (int l = 0; l < kStrandLanes; ++l)
      if (rare[l]) setLane(&r, l, orthonormalize(lane(f, l)));
  return r;
}

/// Signed distance to the head (HeadShape::distance) of head-frame points, lane by lane; the
/// lanes at the centre of a shape take the scalar function.
inline D4 headDistanceLanes(const HeadShape& head, const V3L& x_head, V3L* normal) {
  const EllipsoidShape& e = head.ellipsoid;
  const V3L x = x_head - splat(e.center_m);
  const V3L q = {x.x / splat(e.radii_m.x()), x.y / splat(e.radii_m.y()),
                 x.z / splat(e.radii_m.z())};
  const V3L g = {q.x / splat(e.radii_m.x()), q.y / splat(e.radii_m.y()),
                 q.z / splat(e.radii_m.z())};
  const D4 k0 = vsqrt(dot(q, q));
  const D4 k1 = vsqrt(dot(g, g));
  M4 rare = k1 < splat(1e-12);
  *normal = g / k1;
  D4 best = k0 * (k0 - splat(1.0)) / k1;
  for (const CapsuleShape& c : head.capsules) {
    const Vec3 ab = c.b_m - c.a_m;
    const double len2 = ab.squaredNorm();
    const V3L a = splat(c.a_m);
    D4 s = splat(0.0);
    if (len2 > 0.0)
      s = vmin(vmax(dot(x_head - a, splat(ab)) / splat(len2), splat(0.0)), splat(1.0));
    const V3L dd = x_head - (a + s * splat(ab));
    const D4 len = vsqrt(dot(dd, dd));
    rare |= len < splat(1e-12);
    const D4 dist = len - splat(c.radius_m);
    const M4 closer = dist < best;
    *normal = select(closer, dd / len, *normal);
    best = closer ? dist : best;
  }
  if (any(rare)) {
    for (int l = 0; l < kStrandLanes; ++l) {
      if (!rare[l]) continue;
      Vec3 n;
      best[l] = head.distance(lane(x_head, l), &n);
      setLane(normal, l, n);
    }
  }
  return best;
}

/// collideParticle() on the lanes of `contact`.
inline void collideLanes(M4 contact, D4 d, const V3L& n, double delta, double mu,
                         const V3L& v_obstacle, V3L* x, V3L* v) {
  *x = select(contact, *x + (splat(delta) - d) * n, *x);
  const V3L vrel = *v - v_obstacle;
  const D4 vn = dot(vrel, n);
  const M4 approaching = contact & (vn < splat(0.0));
  V3L vt = vrel - vn * n;
  const D4 vt_len = vsqrt(dot(vt, vt));
  const D4 scale = vt_len > splat(1e-15) ? vmax(splat(0.0), splat(1.0) - splat(mu) * (-vn) / vt_len)
                                         : splat(0.0);
  vt = scale * vt;
  *v = select(approaching, v_obstacle + vt, *v);
}

inline uint64_t laneCount(M4 m, int l) { return m[l] != 0 ? 1 : 0; }

// The damping forces of eqs. (1), (4), (5) and the velocity clamp (springs.h), lane by lane.
inline V3L stretchDampingLanes(const V3L& edge, const V3L& dv, double c_s) {
  const D4 len2 = dot(edge, edge);
  return select(len2 < splat(kDirectionEpsilon * kDirectionEpsilon), zero3(),
                (splat(c_s) * dot(dv, edge) / len2) * edge);
}
inline V3L bendDampingLanes(const V3L& edge, const V3L& dv, double c_b) {
  const D4 len2 = dot(edge, edge);
  return select(len2 < splat(kDirectionEpsilon * kDirectionEpsilon), splat(c_b) * dv,
                splat(c_b) * (dv - (dot(dv, edge) / len2) * edge));
}
inline V3L coreDampingLanes(const V3L& b, const V3L& nu, double c_c) {
  const D4 len2 = dot(b, b);
  return select(len2 < splat(1e-18), zero3(), (splat(c_c) * dot(nu, b) / len2) * b);
}
inline V3L clampAxialLanes(const V3L& edge, const V3L& v_root_side, const V3L& v_tip_side,
                           D4 max_axial_speed) {
  const D4 len = vsqrt(dot(edge, edge));
  const V3L e = edge / len;
  const D4 a = dot(v_tip_side - v_root_side, e);
  const M4 short_edge = len < splat(kDirectionEpsilon);
  const M4 above = ~short_edge & (a > max_axial_speed);
  const M4 below = ~short_edge & ~above & (a < -max_axial_speed);
  V3L r = select(above, v_tip_side - (a - max_axial_speed) * e, v_tip_side);
  return select(below, v_tip_side - (a + max_axial_speed) * e, r);
}

/// Lanes whose obstacle distance must be evaluated at x. A signed distance changes by at most
/// L |dx| when the point moves by dx: L = 1 for the analytic shapes (and the field's extension
/// outside its box), L <= sqrt(3) for the trilinear field (each partial derivative is a weighted
/// mean of sample differences over one voxel, at most one voxel each). While 2 |x - anchor| stays
/// below the slack, the distance is still beyond the reach of collision and adhesion, so neither
/// can act and the evaluation is skipped: same result, less work where a strand near an
/// obstacle has most of its particles far from it.
inline M4 obstacleDistanceNeeded(const V3L& x, const V3L& anchor, D4 slack) {
  const V3L dx = x - anchor;
  const M4 still_beyond = (slack > splat(0.0)) & (splat(4.0) * dot(dx, dx) < slack * slack);
  return ~still_beyond;
}

}  // namespace

double stepStrandBlock(const HairModel& model, const SolverConfig& config, const StepInputs& inputs,
                       int first_strand, const StrandFlags* flags, int nsub, double h,
                       HairState* state, StrandScratch* scratch, StepStats* stats) {
  const int n = model.strandSize(first_strand);
  const int edges = n - 1;
  int begin[kStrandLanes], strand[kStrandLanes];
  for (int l = 0; l < kStrandLanes; ++l) {
    strand[l] = first_strand + l;
    begin[l] = model.strandBegin(strand[l]);
  }
  LaneArrays a = carve(scratch);
  const double theta = integratorTheta(config.integrator);
  const bool implicit = theta > 0.0;
  const int damping_passes = implicit ? 0 : dampingPassCount(model, config, h);
  const double clamp_rate = config.stretch.strain_rate_limit_per_substep / h;

  // Per-lane stage switches, the same as the scalar path's per strand.
  const Obstacles* obstacles = inputs.obstacles;
  const bool have_obstacles = obstacles && !obstacles->empty();
  bool curl_on[kStrandLanes], obstacle_on[kStrandLanes], adhesion_on[kStrandLanes],
      stiffness_on[kStrandLanes];
  bool any_curl = false, any_obstacle = false, any_adhesion = false, any_stiffness = false;
  const bool curl_spring = config.curl.mode == "spring";
  for (int l = 0; l < kStrandLanes; ++l) {
    curl_on[l] = flags[l].wet && config.curl.enabled && config.curl.weight_n_per_m > 0.0;
    obstacle_on[l] = flags[l].near_obstacle && have_obstacles;
    adhesion_on[l] = obstacle_on[l] && flags[l].wet && config.adhesion.enabled &&
                     config.adhesion.peak_acceleration_m_s2 > 0.0;
    stiffness_on[l] = stiffnessActive(config, flags[l]);
    any_curl |= curl_on[l];
    any_obstacle |= obstacle_on[l] && config.obstacle.enabled;
    any_adhesion |= adhesion_on[l];
    any_stiffness |= stiffness_on[l];
  }
  const M4 curl_mask = laneMask(curl_on);
  const M4 stiffness_mask = laneMask(stiffness_on);

  // Gather: state and the model's per-particle constants into lanes.
  for (int l = 0; l < kStrandLanes; ++l) {
    prepareStrandStep(model, config, strand[l], flags[l], h, *state, scratch);
    for (int i = 0; i < n; ++i) {
      const int k = begin[l] + i;
      setLane(&a.p[i], l, state->position[k]);
      setLane(&a.v[i], l, state->velocity[k]);
      a.sigma[i][l] = state->saturation[k];
      a.m[i][l] = model.mass_kg[k];
      a.inv_m[i][l] = model.inv_mass[k];
      a.factor[i][l] = stiffness_on[l] ? scratch->velocity_factor[i] : 1.0;
      a.obstacle_slack[i][l] = -1.0;
      if (i < edges) {
        a.rest[i][l] = model.rest_edge_m[k];
        a.core_rest[i][l] = model.core_rest_m[k];
        setLane(&a.local_target[i], l, model.bend_local_target[k]);
        setLane(&a.helix_edge[i], l, model.helix_edge[k]);
      }
    }
  }
  D4 beta_bend, beta_core;
  for (int l = 0; l < kStrandLanes; ++l) {
    beta_bend[l] = model.beta_bend[strand[l]];
    beta_core[l] = model.beta_core[strand[l]];
  }
  // Lane-wise temporaries for the scalar fallbacks (one strand at a time).
  Vec3* p_one = scratch->force.data();
  Vec3* v_one = scratch->rhs.data();

  const double ks = config.stretch.stiffness_n_per_m;
  const double kb = config.bend.stiffness_n_per_m;
  const double kc = config.core.stiffness_n_per_m;
  const double cs = config.stretch.damping_ns_per_m;
  const double cb = config.bend.damping_ns_per_m;
  const double cc = config.core.damping_ns_per_m;
  const double th = theta * h;
  const D4 local_core = (splat(1.0) - beta_core) * (splat(1.0) - beta_core);
  D4 kw = splat(0.0);
  if (curl_spring)
    for (int l = 0; l < kStrandLanes; ++l) kw[l] = curl_on[l] ? config.curl.weight_n_per_m : 0.0;
  const V3L gravity = splat(config.gravity_m_s2);
  D4 max_strain = splat(0.0);
  const double limit = config.stretch.strain_limit;
  const bool inelastic_limit = config.stretch.limit_velocity == "inelastic";
  // Beyond this distance neither obstacle collision (offset) nor adhesion (kernel support) acts.
  const double obstacle_reach = std::max(config.obstacle.offset_m, config.adhesion.radius_m);
  auto obstacleDistance = [&](int i, int l, Vec3* normal) {
    const Vec3 x = lane(a.p[i], l);
    const double dist = obstacles->distance(x, normal);
    setLane(&a.obstacle_anchor[i], l, x);
    a.obstacle_slack[i][l] = dist - obstacle_reach;
    return dist;
  };

  for (int k = 0; k < nsub; ++k) {
    StageLaps laps(inputs.clock, stats);
    const SubstepMotion motion = substepMotion(inputs, double(k) / nsub, double(k + 1) / nsub, h);
    const V3L omega = splat(motion.omega);

    // 1. Roots.
    V3L root_next;
    M3L frame;
    for (int l = 0; l < kStrandLanes; ++l) {
      setLane(&root_next, l, motion.pose1.apply(model.rest_position_head[begin[l]]));
      setLane(&frame, l, motion.r0 * model.root_frame_head[strand[l]]);
    }
    a.v[0] = (root_next - a.p[0]) / splat(h);

    // 2. Smoothed curves, frames, bend targets.
    smoothDifferences(a.p, n, beta_bend, a.d);
    {
      V3L t_prev = column(frame, 0);
      a.target[0] = frame * a.local_target[0];
      for (int i = 1; i < edges; ++i) {
        const V3L& di = a.d[i - 1];
        const D4 len = vsqrt(dot(di, di));
        const M4 keep = len < splat(kDirectionEpsilon);
        const V3L t = di / len;
        const D4 c = dot(t_prev, t);
        M3L next = rodrigues(t_prev, t, c) * frame;
        const M4 opposite = ~keep & (c < splat(-0.99));
        if (any(opposite))
          for (int l = 0; l < kStrandLanes; ++l)
            if (opposite[l])
              setLane(&next, l, minimalRotation(lane(t_prev, l), lane(t, l)) * lane(frame, l));
        if ((i & 15) == 0) next = orthonormalizeLanes(next);
        frame = select(keep, frame, next);
        t_prev = select(keep, t_prev, t);
        a.target[i] = frame * a.local_target[i];
      }
    }
    smoothDifferences(a.p, n, beta_core, a.b);
    laps.lap(kStageFrames, uint64_t(n) * kStrandLanes);

    // 3. Gravity, stretch, bend and core springs.
    for (int i = 0; i < n; ++i) a.f[i] = a.m[i] * gravity;
    for (int i = 0; i < edges; ++i) {
      const V3L e = a.p[i + 1] - a.p[i];
      const D4 len = vsqrt(dot(e, e));
      const V3L stretch = select(len < splat(kDirectionEpsilon), zero3(),
                                 (splat(ks) * (len - a.rest[i]) / len) * e);
      const V3L bend = splat(kb) * (e - a.target[i]);
      const D4 core_len = vsqrt(dot(a.b[i], a.b[i]));
      const V3L core = select(core_len < splat(1e-9), zero3(),
                              (splat(kc) * (core_len - a.core_rest[i]) / core_len) * a.b[i]);
      const V3L fs = stretch + bend + core;
      a.f[i] += fs;
      a.f[i + 1] -= fs;
    }
    laps.lap(kStageForces, uint64_t(n) * kStrandLanes);

    // Curl exaggeration (eqs. 6-9), wet lanes.
    if (any_curl) {
      M3L rot = splat(Mat3(Mat3::Identity()));
      for (int l = 0; l < kStrandLanes; ++l) {
        if (!curl_on[l]) continue;
        updateCurlRotation(model, config.curl, strand[l], lane(a.p[0], l), lane(a.p[n - 1], l), h,
                           state);
        setLane(&rot, l, state->curl_rotation[strand[l]]);
      }
      const D4 w = splat(config.curl.weight_n_per_m);
      for (int i = 0; i < edges; ++i) {
        const D4 s = splat(0.5) * (a.sigma[i] + a.sigma[i + 1]);
        const M4 on = curl_mask & (s > splat(0.0));
        const V3L rotated = rot * a.helix_edge[i];
        const V3L u = curl_spring ? (w * s) * (rotated - (a.p[i + 1] - a.p[i])) : (w * s) * rotated;
        const V3L masked = select(on, u, zero3());
        a.f[i + 1] += masked;
        a.f[i] -= masked;
      }
      uint64_t lanes_on = 0;
      for (int l = 0; l < kStrandLanes; ++l) lanes_on += curl_on[l];
      stats->curl_particle_substeps += uint64_t(n) * lanes_on;
      laps.lap(kStageCurl, uint64_t(n) * lanes_on);
    }
    // Adhesion (eqs. 11-12): reads the obstacle field, lane by lane.
    if (any_adhesion) {
      const double hk = config.adhesion.radius_m;
      const bool literal = config.adhesion.literal_polynomial;
      const double scale = config.adhesion.peak_acceleration_m_s2 / adhesionKernelPeak(hk, literal);
      uint64_t evaluated = 0;
      for (int i = 1; i < n; ++i) {
        const M4 needed = obstacleDistanceNeeded(a.p[i], a.obstacle_anchor[i], a.obstacle_slack[i]);
        for (int l = 0; l < kStrandLanes; ++l) {
          const double sigma = a.sigma[i][l];
          if (!adhesion_on[l] || sigma <= 0.0 || !needed[l]) continue;
          ++evaluated;
          Vec3 normal;
          const double dist = obstacleDistance(i, l, &normal);
          const double ak = adhesionKernel(dist, hk, literal);
          if (ak <= 0.0) continue;
          setLane(&a.f[i], l, lane(a.f[i], l) - (sigma * a.m[i][l] * scale * ak) * normal);
          ++stats->adhesion_active;
        }
      }
      stats->adhesion_particle_substeps += evaluated;
      laps.lap(kStageAdhesion, evaluated);
    }

    if (!implicit) {
      // 4. Velocity update (semi-implicit Euler), roots excluded; 5. the damping passes.
      for (int i = 1; i < n; ++i) a.v[i] += (splat(h) * a.inv_m[i]) * a.f[i];
      const D4 tau = splat(h / damping_passes);
      for (int pass = 0; pass < damping_passes; ++pass) {
        if (cc > 0.0) smoothDifferences(a.v, n, beta_core, a.nu);
        for (int i = 0; i < n; ++i) a.f[i] = zero3();
        for (int i = 0; i < edges; ++i) {
          const V3L e = a.p[i + 1] - a.p[i];
          const V3L dv = a.v[i + 1] - a.v[i];
          V3L fd = stretchDampingLanes(e, dv, cs) + bendDampingLanes(e, dv - cross(omega, e), cb);
          if (cc > 0.0) fd += coreDampingLanes(a.b[i], a.nu[i], cc);
          a.f[i] += fd;
          a.f[i + 1] -= fd;
        }
        for (int i = 1; i < n; ++i) a.v[i] += (tau * a.inv_m[i]) * a.f[i];
      }
      // Velocity clamp root -> tip (Iben §2.2a), explicit only (substepStrand says why).
      for (int i = 0; i < edges; ++i) {
        const V3L vnew =
            clampAxialLanes(a.p[i + 1] - a.p[i], a.v[i], a.v[i + 1], splat(clamp_rate) * a.rest[i]);
        const M4 changed =
            (vnew.x != a.v[i + 1].x) | (vnew.y != a.v[i + 1].y) | (vnew.z != a.v[i + 1].z);
        if (!any(changed)) continue;
        a.v[i + 1] = vnew;
        for (int l = 0; l < kStrandLanes; ++l) stats->velocity_clamps += laneCount(changed, l);
      }
    } else {
      // 4-5 implicit: the theta method of substepStrand, the block-tridiagonal solve per lane.
      if (cc > 0.0) smoothDifferences(a.v, n, beta_core, a.nu);
      for (int i = 0; i < edges; ++i) {
        const V3L e = a.p[i + 1] - a.p[i];
        const V3L dv = a.v[i + 1] - a.v[i];
        // axialSpringJacobian for the stretch and the core springs.
        const D4 len = vsqrt(dot(e, e));
        const M4 stretch_degenerate = len < splat(kDirectionEpsilon);
        const V3L u = select(stretch_degenerate, zero3(), e / len);
        const D4 stretch_iso = stretch_degenerate
                                   ? splat(0.0)
                                   : splat(ks) * vmax(splat(0.0), splat(1.0) - a.rest[i] / len);
        const D4 stretch_axial = stretch_degenerate ? splat(0.0) : splat(ks) - stretch_iso;
        const D4 core_len = vsqrt(dot(a.b[i], a.b[i]));
        const M4 core_degenerate = core_len < splat(kDirectionEpsilon);
        const V3L w = select(core_degenerate, zero3(), a.b[i] / core_len);
        const D4 kcl = splat(kc) * local_core;
        const D4 core_iso = core_degenerate
                                ? splat(0.0)
                                : kcl * vmax(splat(0.0), splat(1.0) - a.core_rest[i] / core_len);
        const D4 core_axial = core_degenerate ? splat(0.0) : kcl - core_iso;
        const D4 curl =
            kw > splat(0.0) ? kw * splat(0.5) * (a.sigma[i] + a.sigma[i + 1]) : splat(0.0);
        const D4 has_axis = dot(u, u) > splat(0.0) ? splat(1.0) : splat(0.0);
        const D4 tth = splat(th);
        const D4 alpha = tth * (splat(cb) + tth * (stretch_iso + core_iso + splat(kb) + curl));
        const D4 beta = tth * (has_axis * splat(cs - cb) + tth * stretch_axial);
        const D4 gamma = tth * (splat(cc) * local_core + tth * core_axial);
        a.block[i] = isotropicPlusDyads(alpha, beta, u, gamma, w);
        V3L fe = splat(-cb) * cross(omega, e);
        if (cc > 0.0) {
          fe += coreDampingLanes(a.b[i], a.nu[i], cc) - (splat(cc) * local_core * dot(w, dv)) * w;
        }
        a.f[i] += fe;
        a.f[i + 1] -= fe;
      }
      for (int i = 0; i < n; ++i) a.v_start[i] = a.v[i];
      for (int i = 1; i < n; ++i) a.rhs[i] = a.m[i] * a.v[i] + splat(th) * a.f[i];
      a.rhs[1] += a.block[0] * a.v[0];
      for (int i = 1; i < n; ++i) {
        M3L pivot = a.block[i - 1];
        for (int r = 0; r < 3; ++r) pivot.m[r][r] += a.m[i];
        if (i < edges) pivot = pivot + a.block[i];
        if (i > 1) {
          const M3L w = a.block[i - 1] * a.pivot_inverse[i - 1];
          pivot = pivot - w * a.block[i - 1];
          a.rhs[i] += w * a.rhs[i - 1];
        }
        a.pivot_inverse[i] = inverse(pivot);
      }
      a.v[n - 1] = a.pivot_inverse[n - 1] * a.rhs[n - 1];
      for (int i = n - 2; i >= 1; --i)
        a.v[i] = a.pivot_inverse[i] * (a.rhs[i] + a.block[i] * a.v[i + 1]);
      const D4 inv_theta = splat(1.0 / theta);
      for (int i = 1; i < n; ++i) a.v[i] = a.v_start[i] + inv_theta * (a.v[i] - a.v_start[i]);
    }

    // 6. Stiffness, eq. (13), on the lanes it acts on.
    if (any_stiffness) {
      const V3L head_velocity = splat(motion.head_velocity);
      const V3L origin = splat(motion.pose0.translation);
      for (int i = 1; i < n; ++i) {
        V3L changed;
        if (config.stiffness.relative_to_head) {
          const V3L carried = head_velocity + cross(omega, a.p[i] - origin);
          changed = carried + a.factor[i] * (a.v[i] - carried);
        } else {
          changed = a.factor[i] * a.v[i];
        }
        a.v[i] = select(stiffness_mask, changed, a.v[i]);
      }
    }
    // 8. Positions: with the new velocity (explicit), the theta-weighted one (implicit).
    a.p[0] = root_next;
    if (!implicit) {
      for (int i = 1; i < n; ++i) a.p[i] += splat(h) * a.v[i];
    } else {
      for (int i = 1; i < n; ++i)
        a.p[i] += splat(h) * (splat(1.0 - theta) * a.v_start[i] + splat(theta) * a.v[i]);
    }
    laps.lap(kStageIntegrate, uint64_t(n) * kStrandLanes);

    // 7. Head collision, every lane.
    uint64_t touched[kStrandLanes] = {};
    if (config.collision.head_enabled) {
      const M3L r0 = splat(motion.r0), r1 = splat(motion.r1), r1_inverse = splat(motion.r1_inverse);
      const V3L t0 = splat(motion.pose0.translation), t1 = splat(motion.pose1.translation);
      const double delta = config.collision.offset_m;
      for (int i = 1; i < n; ++i) {
        const V3L x_head = r1_inverse * (a.p[i] - t1);
        V3L n_head;
        const D4 dist = headDistanceLanes(model.head, x_head, &n_head);
        const M4 contact = dist < splat(delta);
        if (!any(contact)) continue;
        const V3L v_head = (a.p[i] - (r0 * x_head + t0)) / splat(h);
        collideLanes(contact, dist, r1 * n_head, delta, config.collision.friction, v_head, &a.p[i],
                     &a.v[i]);
        for (int l = 0; l < kStrandLanes; ++l) touched[l] += laneCount(contact, l);
      }
      for (int l = 0; l < kStrandLanes; ++l) stats->head_contacts += touched[l];
      laps.lap(kStageHeadCollision, uint64_t(n - 1) * kStrandLanes);
    }
    // Obstacles: the field is read lane by lane, with the scalar response, where the distance
    // cache cannot rule a contact out.
    if (any_obstacle) {
      const double delta = config.obstacle.offset_m;
      const double mu = config.obstacle.friction;
      uint64_t evaluated = 0;
      for (int i = 1; i < n; ++i) {
        const M4 needed = obstacleDistanceNeeded(a.p[i], a.obstacle_anchor[i], a.obstacle_slack[i]);
        for (int l = 0; l < kStrandLanes; ++l) {
          if (!(obstacle_on[l] && config.obstacle.enabled) || !needed[l]) continue;
          ++evaluated;
          Vec3 normal;
          const double dist = obstacleDistance(i, l, &normal);
          Vec3 x = lane(a.p[i], l), v = lane(a.v[i], l);
          if (!collideParticle(dist, normal, delta, mu, Vec3::Zero(), &x, &v)) continue;
          setLane(&a.p[i], l, x);
          setLane(&a.v[i], l, v);
          ++stats->obstacle_contacts;
          ++touched[l];
        }
      }
      stats->obstacle_particle_substeps += evaluated;
      laps.lap(kStageObstacleCollision, evaluated);
    }
    // 9. Strain limit root -> tip, every lane.
    uint64_t projected[kStrandLanes] = {};
    for (int i = 0; i < edges; ++i) {
      const V3L e = a.p[i + 1] - a.p[i];
      const D4 len = vsqrt(dot(e, e));
      max_strain = vmax(max_strain, len / a.rest[i] - splat(1.0));
      const D4 max_length = splat(1.0 + limit) * a.rest[i];
      const M4 within = (len <= max_length) | (len < splat(kDirectionEpsilon));
      const V3L disp_raw = (max_length / len) * e - e;
      const V3L disp = select(within, zero3(), disp_raw);
      const M4 moved = dot(disp, disp) > splat(0.0);
      if (!any(moved)) continue;
      a.p[i + 1] = select(moved, a.p[i + 1] + disp, a.p[i + 1]);
      if (inelastic_limit) {
        V3L edge = a.p[i + 1] - a.p[i];
        const D4 len2 = dot(edge, edge);
        edge = select(len2 > splat(0.0), edge / vsqrt(len2), edge);
        const D4 along = dot(a.v[i + 1] - a.v[i], edge);
        a.v[i + 1] = select(moved & (along > splat(0.0)), a.v[i + 1] - along * edge, a.v[i + 1]);
      } else {
        a.v[i + 1] = select(moved, a.v[i + 1] + disp / splat(h), a.v[i + 1]);
      }
      for (int l = 0; l < kStrandLanes; ++l) projected[l] += laneCount(moved, l);
    }
    for (int l = 0; l < kStrandLanes; ++l) {
      stats->strain_limited_edges += projected[l];
      // Further rounds (rare): the scalar code on the lanes that need them.
      if (touched[l] == 0 || projected[l] == 0 || config.collision.constraint_rounds == 0) continue;
      for (int i = 0; i < n; ++i) p_one[i] = lane(a.p[i], l), v_one[i] = lane(a.v[i], l);
      stats->constraint_rounds += extraConstraintRounds(
          model, config, obstacles, obstacle_on[l] && config.obstacle.enabled, motion,
          &model.rest_edge_m[begin[l]], h, touched[l], projected[l], p_one, v_one, n);
      for (int i = 1; i < n; ++i) setLane(&a.p[i], l, p_one[i]), setLane(&a.v[i], l, v_one[i]);
    }
    laps.lap(kStageStrainLimit, uint64_t(n - 1) * kStrandLanes);
  }

  // Scatter.
  for (int l = 0; l < kStrandLanes; ++l) {
    for (int i = 0; i < n; ++i) {
      state->position[begin[l] + i] = lane(a.p[i], l);
      state->velocity[begin[l] + i] = lane(a.v[i], l);
    }
  }
  return std::max(std::max(max_strain[0], max_strain[1]), std::max(max_strain[2], max_strain[3]));
}

}  // namespace detail
}  // namespace wet_curly_hair

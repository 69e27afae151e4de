#include "wet_curly_hair/core/followers.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

#include "display_write.h"
#include "parallel.h"
#include "wet_curly_hair/core/frames.h"
#include "wet_curly_hair/core/smoothing.h"
#include "wet_curly_hair/core/springs.h"
#include "wet_curly_hair/core/wet_kernels.h"

namespace wet_curly_hair {

std::vector<int> selectGuides(const Vec3List& roots, int count) {
  const int n = static_cast<int>(roots.size());
  count = std::max(1, std::min(count, n));
  std::vector<int> chosen;
  if (n == 0) return chosen;
  std::vector<double> nearest(n, std::numeric_limits<double>::infinity());
  int next = 0;
  for (int c = 0; c < count; ++c) {
    chosen.push_back(next);
    int best = -1;
    double best_d = -1.0;
    nearest[next] = -1.0;  // chosen: never again, even where roots coincide
    for (int i = 0; i < n; ++i) {
      if (nearest[i] < 0.0) continue;
      nearest[i] = std::min(nearest[i], (roots[i] - roots[next]).squaredNorm());
      if (nearest[i] > best_d) best_d = nearest[i], best = i;  // strict: lowest index on a tie
    }
    next = best;
  }
  std::sort(chosen.begin(), chosen.end());
  return chosen;
}

void followerWeights(const double* d, int count, double* w) {
  const int k = std::min(count, kFollowerGuides);
  if (k <= 0) return;
  std::fill(w, w + k, 0.0);
  if (d[0] < 1e-9) {
    w[0] = 1.0;
    return;
  }
  const double r = count > kFollowerGuides ? d[kFollowerGuides] : 2.0 * d[count - 1];
  double sum = 0.0;
  for (int i = 0; i < k; ++i) {
    const double q = d[i] < r ? (r - d[i]) / (r * d[i]) : 0.0;
    w[i] = q * q;
    sum += w[i];
  }
  if (!(sum > 0.0)) {  // every guide as far as the next one: equal shares
    std::fill(w, w + k, 1.0 / k);
    return;
  }
  for (int i = 0; i < k; ++i) w[i] /= sum;
}

namespace {

/// The frames of a strand's edges (n - 1 of them) on its curve x smoothed with beta (eq. 2's
/// filter), transported from the root frame; d is scratch of n - 1.
void smoothedFrames(const Vec3* x, int n, const Mat3& root, double beta, Vec3* d, Mat3* frames) {
  smoothDifferences(x, n, beta, d);
  transportFrames(root, d, n - 1, frames);
}

/// Normalized arc length of each particle of strand s (rest shape), into u (0 at the root, 1 at
/// the tip).
void normalizedArcLength(const HairModel& m, int s, std::vector<double>* u) {
  const int begin = m.strandBegin(s), n = m.strandSize(s);
  u->assign(n, 0.0);
  for (int i = 1; i < n; ++i)
    (*u)[i] = (*u)[i - 1] +
              (m.rest_position_head[begin + i] - m.rest_position_head[begin + i - 1]).norm();
  const double total = (*u)[n - 1];
  for (int i = 1; i < n; ++i) (*u)[i] = total > 0.0 ? (*u)[i] / total : 1.0;
  (*u)[n - 1] = 1.0;
}

/// The k nearest guides of follower strand s and their weights.
void nearestGuides(const HairModel& m, int s, int* guide, double* weight) {
  const int guides = m.followers.guide_strands;
  const Vec3 root = m.rest_position_head[m.strandBegin(s)];
  constexpr int kKeep = kFollowerGuides + 1;
  double best_d[kKeep];
  int best_g[kKeep];
  int kept = 0;
  for (int g = 0; g < guides; ++g) {
    const double d = (m.rest_position_head[m.strandBegin(g)] - root).norm();
    if (kept == kKeep && d >= best_d[kKeep - 1]) continue;
    int i = kept < kKeep ? kept++ : kKeep - 1;
    for (; i > 0 && best_d[i - 1] > d; --i) best_d[i] = best_d[i - 1], best_g[i] = best_g[i - 1];
    best_d[i] = d;
    best_g[i] = g;
  }
  double w[kFollowerGuides] = {};
  followerWeights(best_d, kept, w);
  for (int n = 0; n < kFollowerGuides; ++n) {
    guide[n] = n < kept ? best_g[n] : best_g[0];
    weight[n] = n < kept ? w[n] : 0.0;
  }
}

/// Guides, weights and arc-length samples of every follower; the curl turn of every strand.
void attachFollowers(int guides, std::vector<int> source, HairModel* m) {
  FollowerMap& f = m->followers;
  f.guide_strands = guides;
  f.source_strand = std::move(source);
  const int strands = m->strandCount(), followers = strands - guides;
  const int first = m->strandBegin(guides);
  const size_t samples = static_cast<size_t>(m->particleCount() - first) * kFollowerGuides;
  f.guide.assign(static_cast<size_t>(followers) * kFollowerGuides, 0);
  f.weight.assign(static_cast<size_t>(followers) * kFollowerGuides, 0.0);
  f.sample_index.assign(samples, 0);
  f.sample_fraction.assign(samples, 0.0);
  std::vector<std::vector<double>> guide_u(guides);
  for (int g = 0; g < guides; ++g) normalizedArcLength(*m, g, &guide_u[g]);
  std::vector<double> u;
  for (int k = 0; k < followers; ++k) {
    const int s = guides + k;
    nearestGuides(*m, s, &f.guide[k * kFollowerGuides], &f.weight[k * kFollowerGuides]);
    normalizedArcLength(*m, s, &u);
    for (int n = 0; n < kFollowerGuides; ++n) {
      const int g = f.guide[k * kFollowerGuides + n];
      const std::vector<double>& ug = guide_u[g];
      int a = 0;
      for (int i = 0; i < static_cast<int>(u.size()); ++i) {
        while (a + 2 < static_cast<int>(ug.size()) && ug[a + 1] <= u[i]) ++a;
        const double span = ug[a + 1] - ug[a];
        const double t = span > 0.0 ? std::clamp((u[i] - ug[a]) / span, 0.0, 1.0) : 0.0;
        const size_t e = static_cast<size_t>(m->strandBegin(s) + i - first) * kFollowerGuides + n;
        f.sample_index[e] = static_cast<uint32_t>(m->strandBegin(g) + a);
        f.sample_fraction[e] = t;
      }
    }
  }
  f.guide_rest_frame.assign(first, Mat3::Identity());
  Vec3List d(m->max_strand_size);
  for (int g = 0; g < guides; ++g) {
    const int begin = m->strandBegin(g), n = m->strandSize(g);
    smoothedFrames(&m->rest_position_head[begin], n, m->root_frame_head[g], m->beta_core[g],
                   d.data(), &f.guide_rest_frame[begin]);
  }
  f.curl_turn.assign(strands, Mat3::Identity());
  for (int s = 0; s < strands; ++s) {
    const Vec3 axis = m->rest_position_head[m->strandBegin(s) + m->strandSize(s) - 1] -
                      m->rest_position_head[m->strandBegin(s)];
    if (axis.norm() > 1e-12)
      f.curl_turn[s] = helixToHairRotation(m->helix_axis[s], axis.normalized());
  }
}

}  // namespace

GuideChoice guideChoice(const std::string& name) {
  return name == "first" ? GuideChoice::kFirst : GuideChoice::kSampled;
}

bool buildFollowerModel(const Groom& groom, double rho, int follow_ratio, const HeadShape& head,
                        const SolverConfig& config, HairModel* model, std::string* why,
                        GuideChoice choice) {
  if (follow_ratio < 1 || follow_ratio > kMaxFollowRatio) {
    if (why) {
      *why = "groom.follow_ratio: " + std::to_string(follow_ratio) +
             " must be a whole number in [1, " + std::to_string(kMaxFollowRatio) + "]";
    }
    return false;
  }
  if (follow_ratio == 1) return buildModel(groom, rho, head, config, model, why);
  if (!groom.validate(why)) return false;
  const int strands = groom.strandCount();
  const int guides = (strands + follow_ratio - 1) / follow_ratio;
  if (guides >= strands) return buildModel(groom, rho, head, config, model, why);
  std::vector<int> order;
  if (choice == GuideChoice::kFirst) {
    for (int s = 0; s < guides; ++s) order.push_back(s);
  } else {
    Vec3List roots(strands);
    for (int s = 0; s < strands; ++s) roots[s] = groom.points[groom.strand_offsets[s]];
    order = selectGuides(roots, guides);
  }
  std::vector<char> is_guide(strands, 0);
  for (int g : order) is_guide[g] = 1;
  for (int s = 0; s < strands; ++s)
    if (!is_guide[s]) order.push_back(s);
  Groom sorted;
  sorted.points.reserve(groom.points.size());
  for (int s : order) {
    sorted.points.insert(sorted.points.end(), groom.points.begin() + groom.strand_offsets[s],
                         groom.points.begin() + groom.strand_offsets[s + 1]);
    sorted.strand_offsets.push_back(static_cast<uint32_t>(sorted.points.size()));
    sorted.root_normals.push_back(groom.root_normals[s]);
  }
  HairModel m;
  if (!buildModel(sorted, rho, head, config, &m, why)) return false;
  attachFollowers(guides, std::move(order), &m);
  relayModelLanes(&m);  // the guides alone are simulated
  *model = std::move(m);
  return true;
}

void exaggeratedRest(const HairModel& model, const CurlConfig& curl, int s, const double* sigma,
                     Vec3* out) {
  const int begin = model.strandBegin(s), n = model.strandSize(s);
  const Vec3* rest = &model.rest_position_head[begin];
  const double kw = curl.enabled ? model.curl_k[s] : 0.0, kb = model.bend_k[s];
  // The exaggeration is carried as an offset from the rest shape, so that a dry strand is its
  // rest shape to the bit.
  Vec3 offset = Vec3::Zero();
  out[0] = rest[0];
  for (int i = 0; i + 1 < n; ++i) {
    const double sig = 0.5 * (sigma[i] + sigma[i + 1]);
    if (kw > 0.0 && sig > 0.0) {
      const double b = kw * sig / (kw * sig + kb);
      const Vec3 e = rest[i + 1] - rest[i];
      const Vec3 h = model.followers.curl_turn[s] * model.helix_edge[begin + i];
      const Vec3 mix = (1.0 - b) * e + b * h;
      const double len = mix.norm();
      if (len > 0.0) offset += mix * (e.norm() / len) - e;
    }
    out[i + 1] = rest[i + 1] + offset;
  }
}

namespace {

/// Projections out of the head per follower particle: the ellipsoid distance converges in 2-3.
constexpr int kFollowerProjectionRounds = 4;

/// Where a strand's head or obstacle distance was last evaluated and how far a particle may be
/// from there before a projection could act (negative: evaluate): consecutive particles are an
/// edge apart, so a strand hanging centimetres from the head skips most evaluations.
struct DistanceCache {
  Vec3 anchor = Vec3::Zero();
  double slack = -1.0;
  bool covers(const Vec3& x) const { return !distanceNeeded(toV3(x), toV3(anchor), slack); }
};

/// What the caches leave of their slack for round-off.
constexpr double kFollowerCacheMargin_m = 1e-9;

/// Rounds of the edge hold and the projections for a particle a projection moved: where the head
/// and an obstacle pinch the hair they push in turn. Measured (2,000 strands, K = 10, the nod with
/// the sphere): the shortest follower edge 0.18 of rest after 2 rounds, 0.76 after 6, at no cost
/// seen (the rounds after the first run only where a projection acted).
constexpr int kFollowerHoldRounds = 6;

/// The head cache's rule, from the head's lower bound at a particle (projectOutOfHead, and on the
/// lanes projectionsPossible): the slack the cache keeps (the bound is 1-Lipschitz, and no
/// particle of the strand is pushed out farther than max_offset) and whether a projection to
/// `offset` may act; then the cache is left empty, so that the projection evaluates again.
template <typename S>
WCH_INLINE LaneMask<S> headMayAct(const S& bound, const S& offset, double max_offset, S* slack) {
  const LaneMask<S> may_act = !(bound >= offset + splat<S>(HeadShape::kSurelyMargin_m));
  *slack = select(may_act, splat<S>(-1.0),
                  bound - splat<S>(max_offset) - splat<S>(kFollowerCacheMargin_m));
  return may_act;
}

/// The obstacle cache's rule, from the obstacles' distance at a particle (holdAndProject, and on
/// the lanes projectionsPossible): the slack (L = 2 bounds the field's Lipschitz constant,
/// sqrt(3) in strand_block.h, and the shapes' 1) and whether the projection to `offset` acts.
template <typename S>
WCH_INLINE LaneMask<S> obstacleActs(const S& dist, double offset, S* slack) {
  *slack = splat<S>(0.5) * (dist - splat<S>(offset)) - splat<S>(kFollowerCacheMargin_m);
  return dist < splat<S>(offset);
}

/// Pushes head-frame point x out of the head to `offset` (the solver's rule; at most
/// max_offset for every particle of the strand). Returns whether it moved.
bool projectOutOfHead(const HeadShape& head, double offset, double max_offset, DistanceCache* cache,
                      Vec3* x) {
  // Most of a hanging strand is far from the head: the cached 1-Lipschitz bound skips it.
  if (cache->covers(*x)) return false;
  cache->anchor = *x;
  if (!headMayAct(head.lowerBound(*x), offset, max_offset, &cache->slack)) return false;
  bool moved = false;
  // The ellipsoid's distance is approximate off its surface: a deep particle lands short of the
  // offset after one projection, so project again (at most a few times).
  for (int round = 0; round < kFollowerProjectionRounds; ++round) {
    Vec3 normal;
    const double dist = head.distance(*x, &normal);
    if (dist >= offset) break;
    *x += (offset - dist) * normal;
    moved = true;
  }
  return moved;
}

/// Follower strand s's exaggerated rest shape (exaggeratedRest, head frame): the state's copy,
/// computed again where the strand's saturation or its curl or bend constant (the other inputs
/// are the model's) differ from those it was computed with.
const Vec3* followerRest(const HairModel& model, const CurlConfig& curl, int s, HairState* state) {
  const int begin = model.strandBegin(s), n = model.strandSize(s);
  const size_t k = static_cast<size_t>(begin - model.strandBegin(model.followers.guide_strands));
  const size_t f = 2 * static_cast<size_t>(s - model.followers.guide_strands);
  // exaggeratedRest's constants, as it reads them.
  const double kw = curl.enabled ? model.curl_k[s] : 0.0, kb = model.bend_k[s];
  const double* sigma = &state->saturation[begin];
  double* held_sigma = &state->follower_rest_saturation[k];
  double* key = &state->follower_rest_key[f];
  Vec3* held = &state->follower_rest_head[k];
  bool same = key[0] == kw && key[1] == kb;
  // Bit for bit (a vector compare): a zero of the other sign computes the shape again, the same.
  same = same && std::memcmp(held_sigma, sigma, n * sizeof(double)) == 0;
  if (!same) {
    exaggeratedRest(model, curl, s, sigma, held);
    std::copy_n(sigma, n, held_sigma);
    key[0] = kw;
    key[1] = kb;
  }
  return held;
}

/// The followers' lanes: strands placed together in floats, one per lane, as many as one register
/// holds (16 with AVX-512, 8 with AVX2; each lane computes alone, so the positions are the same
/// to the bit either way). The guides' samples are summed in double and rounded once into the
/// lanes, so a follower's positions hold single precision, the precision of every output that
/// carries them (~strands, .hair frames); no error accumulates, since each frame places them
/// anew. On the first-generation EPYC (AVX2 on 128-bit units) 8 floats cost what 4 doubles did:
/// the placement at 0.80-0.92x of lanes of 4 doubles; 16 floats cost what 8 did on Zen 4 and
/// 0.88-0.96x of it on Zen 5 (docs/followers.md).
#if defined(__AVX512F__)
using FollowerLane = LaneFloat16;
#else
using FollowerLane = LaneFloat8;
#endif
constexpr int kFollowerLanes = kLaneWidth<FollowerLane>;

/// x, y, z and a spare of one guide edge's carry (GuideEdgeCarry) in one register.
typedef double CarryQuad __attribute__((vector_size(32)));
WCH_INLINE CarryQuad loadQuad(const double* a) {
  CarryQuad q;
  std::memcpy(&q, a, sizeof q);
  return q;
}
/// Three doubles (a Vec3 of a list) into x, y, z, the spare lane 0: reads nothing past them.
/// Element by element (a copy of 3 doubles into the register's bytes went through the stack, and
/// the load of the whole register waited on the smaller stores: the display pass 1.3x slower).
WCH_INLINE CarryQuad loadTriple(const double* a) { return CarryQuad{a[0], a[1], a[2], 0.0}; }

/// A group of followers' per-particle inputs to the edge hold, lane l holding strand l's, carved
/// from the thread's StrandScratch::lane_buffer: the positions from interpolateFromGuides (head
/// frame), the least guide edge ratio at each particle's samples, the rest length of the edge
/// that ends at the particle and the head offset of the particle (the solver's: never pushed
/// farther out than its rest distance, nor left inside the head).
struct FollowerColumns {
  FollowerLane *x, *y, *z;  ///< the coordinates apart: a copy of a whole V3 went through memory
  FollowerLane* least_ratio;
  FollowerLane* rest_length;
  FollowerLane* head_offset;
};

FollowerColumns carveFollowerColumns(StrandScratch* scratch) {
  constexpr size_t kBytes = sizeof(FollowerLane);
  char* bytes = reinterpret_cast<char*>(scratch->lane_buffer.data());
  bytes += (kBytes - reinterpret_cast<uintptr_t>(bytes) % kBytes) % kBytes;
  const size_t n = scratch->lane_capacity;
  FollowerColumns c;
  c.x = reinterpret_cast<FollowerLane*>(bytes);
  c.y = c.x + n;
  c.z = c.y + n;
  c.least_ratio = c.z + n;
  c.rest_length = c.least_ratio + n;
  c.head_offset = c.rest_length + n;
  return c;
}

/// The first stage of placing a follower, particle by particle: each guide carries the
/// follower's offset from it on the exaggerated rest shapes, turned with its smoothed frame, so
/// rigid motions and large bends of the guides move the offset with them. No particle depends on
/// another here, so their work overlaps: interleaved with the edge hold, which runs root to tip,
/// the placement cost 7-10 % more on the AMD EPYC with AVX2 (10,000 strands, K = 100,
/// bench_follower_placement), the same on the Xeon with AVX-512. rest holds the strand's
/// exaggerated rest positions; lane l of the columns receives its head-frame positions and the
/// least guide edge ratio at each particle's samples.
void interpolateFromGuides(const HairModel& model, const HairState& state, int s, const Vec3* rest,
                           int l, const FollowerColumns& c) {
  const int begin = model.strandBegin(s), n = model.strandSize(s);
  const GuideEdgeCarry* carry = state.guide_edge_carry.data();
  const GuideSamples samples(model, s);
  for (int i = 0; i < n; ++i) {
    // The weights go into the scalars, and the turns are summed before they turn the offset
    // (sum_k w_k T_k r = (sum_k w_k T_k) r): 5 multiply-adds a sample, into 4 independent sums.
    CarryQuad at = splat<CarryQuad>(0.0), turn_x = at, turn_y = at, turn_z = at;
    double ratio = 1.0;
    samples.forEach(begin + i, [&](uint32_t a, double w, double t) {
      const GuideEdgeCarry& e = carry[a];
      at += (w * (1.0 - t)) * loadQuad(e.from);
      at += (w * t) * loadQuad(e.to);
      turn_x += w * loadQuad(e.turn_column[0]);
      turn_y += w * loadQuad(e.turn_column[1]);
      turn_z += w * loadQuad(e.turn_column[2]);
      ratio = std::min(ratio, e.edgeRatio());
    });
    const CarryQuad sum = at + (turn_x * rest[i].x() + turn_y * rest[i].y() + turn_z * rest[i].z());
    setLaneValue(&c.x[i], l, sum[0]);
    setLaneValue(&c.y[i], l, sum[1]);
    setLaneValue(&c.z[i], l, sum[2]);
    setLaneValue(&c.least_ratio[i], l, ratio);
  }
}

/// A guide edge's carry (GuideEdgeCarry) from its turn, its ends less their turned rest positions
/// and its length over its rest length.
void setGuideEdgeCarry(const Mat3& turn, const Vec3& from, const Vec3& to, double edge_ratio,
                       GuideEdgeCarry* carry) {
  for (int col = 0; col < 3; ++col)
    for (int row = 0; row < 3; ++row) carry->turn_column[col][row] = turn(row, col);
  for (int axis = 0; axis < 3; ++axis) {
    carry->from[axis] = from[axis];
    carry->to[axis] = to[axis];
  }
  carry->from[3] = carry->to[3] = edge_ratio;
}

/// What every follower of one placement shares: the pose (as a matrix, computed once: a
/// quaternion product per particle cost more; and on the lanes), the limits and the obstacles.
struct PlacementFrame {
  PlacementFrame(const HairModel& m, const SolverConfig& c, const Pose& p, const Obstacles* o,
                 double dt_s)
      : model(m), config(c), pose(p), obstacles(o), inverse_dt(dt_s > 0.0 ? 1.0 / dt_s : 0.0) {
    const Mat3 r = pose.rotation.toRotationMatrix();
    rotation = splat33<double>(r);
    rotation_lanes = splat33<FollowerLane>(r);
  }
  const HairModel& model;
  const SolverConfig& config;
  const Pose& pose;
  const Obstacles* obstacles;
  double inverse_dt;
  M33<double> rotation;
  M33<FollowerLane> rotation_lanes;  ///< splat once: the hold transforms every particle
  V3<double> toWorld(const V3<double>& x) const { return rotation * x + toV3(pose.translation); }
  /// World positions on the lanes relative to the head's position (the pose's translation): in
  /// float lanes a world coordinate 1 km from the origin would hold 60 um, one relative to the
  /// head holds what the head frame does. The translation is added in double where a position
  /// leaves the lanes (storeFollowerParticles, LaneDistanceCaches).
  V3<FollowerLane> toWorldFromHead(const V3<FollowerLane>& x) const { return rotation_lanes * x; }
};

/// One follower in a group being placed: its range of particles and whether an obstacle is within
/// its reach.
struct FollowerInGroup {
  int begin = 0, n = 0;
  bool near_obstacle = false;
};

/// The first stage of placing follower strand s in lane l: its exaggerated rest shape, whether
/// an obstacle is within its reach (from its rest root: the strand cannot reach farther), its
/// positions from its guides and its edges' inputs to the hold.
FollowerInGroup startFollower(const PlacementFrame& frame, int s, int l, const FollowerColumns& c,
                              HairState* state) {
  const HairModel& model = frame.model;
  FollowerInGroup f;
  f.begin = model.strandBegin(s);
  f.n = model.strandSize(s);
  const Vec3* rest = followerRest(model, frame.config.curl, s, state);
  const ObstacleCollisionConfig& oc = frame.config.obstacle;
  if (frame.obstacles && oc.enabled && !frame.obstacles->empty()) {
    Vec3 normal;
    const double reach = model.strand_length_m[s] + oc.margin_m + oc.offset_m;
    f.near_obstacle = frame.obstacles->distance(frame.pose.apply(rest[0]), &normal) <= reach;
  }
  interpolateFromGuides(model, *state, s, rest, l, c);
  const double head_offset = frame.config.collision.offset_m;
  for (int i = 1; i < f.n; ++i) {
    setLaneValue(&c.rest_length[i], l, model.rest_edge_m[f.begin + i - 1]);
    // The solver's rule (collideHeadParticles): a particle authored inside the head is pushed to
    // its surface, not left at its rest depth.
    setLaneValue(&c.head_offset[i], l,
                 std::min(head_offset, std::max(0.0, model.rest_head_distance_m[f.begin + i])));
  }
  return f;
}

/// One follower edge's hold: the particle before (head frame) and the lengths it is held within.
struct HeldEdge {
  Vec3 before;
  double min_length, max_length;
  double head_offset;  ///< the particle's (FollowerColumns::head_offset)
};

/// The hold of a follower's edge and the projections of its tip particle x (head frame; its world
/// position returned). The interpolation keeps no length: where the guides bend or part
/// differently, their turned offsets stretch and crush the follower's edges (measured to 6x and
/// 1/20 of rest, 10,000 strands at K = 10). Each edge is held, root to tip, within the solver's
/// strain limit and compressed no more than 1 - limit or the least of its guides' edges there (a
/// follower on a guide's root stays the guide's copy); then the projections. A projection can
/// crush the edge it ends (a particle pushed straight out lands beside the one before it): while
/// one moves the particle, the edge is held and the particle projected again
/// (kFollowerHoldRounds). x arrives held once (on the lanes, placeFollowers).
Vec3 holdAndProject(const PlacementFrame& frame, const HeldEdge& edge, bool near_obstacle,
                    DistanceCache* head_cache, DistanceCache* obstacle_cache, Vec3* x) {
  const CollisionConfig& hc = frame.config.collision;
  const ObstacleCollisionConfig& oc = frame.config.obstacle;
  V3<double> world;
  for (int pass = 0; pass < kFollowerHoldRounds; ++pass) {
    if (pass > 0)
      *x += toEigen(clampEdgeLength(toV3(edge.before), toV3(*x), edge.min_length, edge.max_length));
    bool moved = hc.head_enabled &&
                 projectOutOfHead(frame.model.head, edge.head_offset, hc.offset_m, head_cache, x);
    world = frame.toWorld(toV3(*x));
    if (near_obstacle && !obstacle_cache->covers(toEigen(world))) {
      Vec3 normal;
      const double dist = frame.obstacles->distance(toEigen(world), &normal);
      obstacle_cache->anchor = toEigen(world);
      if (obstacleActs(dist, oc.offset_m, &obstacle_cache->slack)) {
        world += toV3((oc.offset_m - dist) * normal);
        *x = toEigen(frame.rotation).transpose() * (toEigen(world) - frame.pose.translation);
        moved = true;
      }
    }
    if (!moved) break;
  }
  return toEigen(world);
}

/// The group's placed particles, held in the columns x, y, z (each particle's world position
/// relative to the head's position, PlacementFrame::toWorldFromHead, written over its head-frame
/// position once that was read), stored strand by strand: world positions and velocities over
/// the frame. Storing particle i of every lane as it was placed kept 3 streams per lane in
/// flight (2 written, 1 read), and the placement waited on the old positions' loads (the
/// followers' stage took 1.1x as long).
void storeFollowerParticles(const PlacementFrame& frame, const FollowerInGroup* group, int count,
                            const FollowerColumns& c, HairState* state) {
  for (int l = 0; l < count; ++l) {
    Vec3* p = &state->position[group[l].begin];
    Vec3* v = &state->velocity[group[l].begin];
    for (int i = 0; i < group[l].n; ++i) {
      const Vec3 w = Vec3(laneValue(c.x[i], l), laneValue(c.y[i], l), laneValue(c.z[i], l)) +
                     frame.pose.translation;
      v[i] = frame.inverse_dt * (w - p[i]);
      p[i] = w;
    }
  }
}

/// Particle i's world position relative to the head's position, on the lanes, into the columns.
WCH_INLINE void holdPlaced(const FollowerColumns& c, int i, const V3<FollowerLane>& world) {
  c.x[i] = world.x, c.y[i] = world.y, c.z[i] = world.z;
}

/// A group's distance caches (DistanceCache) on the lanes: the head's in the head frame, the
/// obstacles' in the world relative to the head's position (origin; PlacementFrame::
/// toWorldFromHead), as holdAndProject's are in the world itself.
struct LaneDistanceCaches {
  explicit LaneDistanceCaches(const Vec3& head_position) : origin(head_position) {}
  Vec3 origin;
  V3<FollowerLane> head_anchor = zero3<FollowerLane>(), obstacle_anchor = zero3<FollowerLane>();
  FollowerLane head_slack = splat<FollowerLane>(-1.0), obstacle_slack = splat<FollowerLane>(-1.0);
  DistanceCache head(int l) const { return {lane(head_anchor, l), laneValue(head_slack, l)}; }
  DistanceCache obstacle(int l) const {
    return {lane(obstacle_anchor, l) + origin, laneValue(obstacle_slack, l)};
  }
  void set(int l, const DistanceCache& head, const DistanceCache& obstacle) {
    setLane(&head_anchor, l, head.anchor);
    setLaneValue(&head_slack, l, head.slack);
    setLane(&obstacle_anchor, l, Vec3(obstacle.anchor - origin));
    setLaneValue(&obstacle_slack, l, obstacle.slack);
  }
};

/// The first tests of holdAndProject's projections on the lanes of `lanes`, at head-frame
/// positions x (world: world) after the first hold: the head's lower bound and the obstacles'
/// distance where the caches do not cover a lane, the caches updated as projectOutOfHead and
/// holdAndProject update them. Returns the lanes where a projection may act: there
/// holdAndProject evaluates again (the caches left empty for it) and projects. world is
/// relative to the head's position (PlacementFrame::toWorldFromHead).
LaneMask<FollowerLane> projectionsPossible(const PlacementFrame& frame,
                                           const LaneMask<FollowerLane>& lanes,
                                           const LaneMask<FollowerLane>& near_obstacle,
                                           const V3<FollowerLane>& x, const V3<FollowerLane>& world,
                                           const FollowerLane& head_offset,
                                           LaneDistanceCaches* caches) {
  using S = FollowerLane;
  const CollisionConfig& hc = frame.config.collision;
  LaneMask<S> possible{};  // none
  const LaneMask<S> head_test = lanes && distanceNeeded(x, caches->head_anchor, caches->head_slack);
  if (hc.head_enabled && anyLane(head_test)) {
    S slack;
    const LaneMask<S> may_act =
        headMayAct(frame.model.head.lowerBound(x), head_offset, hc.offset_m, &slack);
    caches->head_anchor = select(head_test, x, caches->head_anchor);
    caches->head_slack = select(head_test, slack, caches->head_slack);
    possible = possible || (head_test && may_act);
  }
  const LaneMask<S> obstacle_test =
      lanes && near_obstacle &&
      distanceNeeded(world, caches->obstacle_anchor, caches->obstacle_slack);
  if (anyLane(obstacle_test)) {
    V3<S> normal;
    const S dist = frame.obstacles->distance(world, caches->origin, obstacle_test, &normal);
    S slack;
    const LaneMask<S> acts = obstacleActs(dist, frame.config.obstacle.offset_m, &slack);
    caches->obstacle_anchor = select(obstacle_test, world, caches->obstacle_anchor);
    caches->obstacle_slack = select(obstacle_test, slack, caches->obstacle_slack);
    possible = possible || (obstacle_test && acts);
  }
  return possible;
}

/// Places follower strands [first, first + count), count <= kFollowerLanes, one per lane (see
/// updateFollowers): each one's positions from its guides (startFollower), then root to tip the
/// edge hold on the lanes, each instruction holding 8 strands' edges and testing their distance
/// caches (one strand at a time, the placement ran about 400 instructions per particle; running
/// 4 strands' scalar holds in turn, to overlap their chains, gained nothing). Where a projection
/// may act on a lane, that lane's projections run alone (holdAndProject, as do the later rounds).
/// The root stays where its guides' roots carry it.
void placeFollowers(const PlacementFrame& frame, int first, int count, const FollowerColumns& c,
                    HairState* state) {
  using S = FollowerLane;
  FollowerInGroup group[kFollowerLanes];
  S strand_size = splat<S>(0.0), near_obstacle = splat<S>(0.0);
  int longest = 0;
  for (int l = 0; l < count; ++l) {
    group[l] = startFollower(frame, first + l, l, c, state);
    setLaneValue(&strand_size, l, group[l].n);
    setLaneValue(&near_obstacle, l, group[l].near_obstacle ? 1.0 : 0.0);
    longest = std::max(longest, group[l].n);
  }
  const double strain_limit = frame.config.stretch.strain_limit;
  const LaneMask<S> near = near_obstacle > splat<S>(0.0);
  LaneDistanceCaches caches(frame.pose.translation);
  V3<S> before{c.x[0], c.y[0], c.z[0]};
  S ratio_before = c.least_ratio[0];
  holdPlaced(c, 0, frame.toWorldFromHead(before));
  for (int i = 1; i < longest; ++i) {
    V3<S> x{c.x[i], c.y[i], c.z[i]};
    const S ratio = c.least_ratio[i];
    // The guides' edges between the samples of the edge's two ends: no shorter than theirs.
    const S min_length =
        vmin(splat<S>(1.0 - strain_limit), vmin(ratio, ratio_before)) * c.rest_length[i];
    const S max_length = splat<S>(1.0 + strain_limit) * c.rest_length[i];
    x += clampEdgeLength(before, x, min_length, max_length);
    V3<S> world = frame.toWorldFromHead(x);  // relative to the head's position
    const LaneMask<S> on = splat<S>(i) < strand_size;
    patchLanes(projectionsPossible(frame, on, near, x, world, c.head_offset[i], &caches),
               [&](int l) {
                 const HeldEdge edge{lane(before, l), laneValue(min_length, l),
                                     laneValue(max_length, l), laneValue(c.head_offset[i], l)};
                 DistanceCache head = caches.head(l), obstacle = caches.obstacle(l);
                 Vec3 xl = lane(x, l);
                 const Vec3 placed =
                     holdAndProject(frame, edge, group[l].near_obstacle, &head, &obstacle, &xl);
                 setLane(&world, l, Vec3(placed - frame.pose.translation));
                 setLane(&x, l, xl);
                 caches.set(l, head, obstacle);
               });
    holdPlaced(c, i, world);
    // Coordinate by coordinate: GCC copied the whole V3 through memory in halves, and the loads of
    // whole lanes that followed waited for them.
    before.x = x.x, before.y = x.y, before.z = x.z;
    ratio_before = ratio;
  }
  storeFollowerParticles(frame, group, count, c, state);
}

}  // namespace

int displayFollowersFromGuides(const HairModel& model, const CohesionConfig& config,
                               HairState* state, int threads) {
  const FollowerMap& f = model.followers;
  if (f.guide_strands <= 0) return 0;
  const int followers = model.strandCount() - f.guide_strands;
  const double* offset = state->guide_clump_offset.data()->data();
  const detail::DisplayWrite write = detail::displayWrite(config, state);
  return static_cast<int>(detail::parallelSum(threads, 16, followers, [&](int k) -> int {
    const int s = f.guide_strands + k, begin = model.strandBegin(s);
    const GuideSamples samples(model, s);
    int moved = 0;
    for (int i = begin; i < begin + model.strandSize(s); ++i) {
      const Vec3& p = state->position[i];
      if (state->saturation[i] <= 0.0) {  // dry particles keep p^w = p
        write.unmoved(i, p);
        continue;
      }
      // x, y, z of the offsets in one register (the spare lane 0): two per sample.
      CarryQuad d = splat<CarryQuad>(0.0);
      samples.forEach(i, [&](uint32_t a, double w, double t) {
        d += w * ((1.0 - t) * loadTriple(offset + 3 * size_t(a)) +
                  t * loadTriple(offset + 3 * (size_t(a) + 1)));
      });
      // Every guide sample isolated: p^w = p (A13).
      if (d[0] == 0.0 && d[1] == 0.0 && d[2] == 0.0) {
        write.unmoved(i, p);
        continue;
      }
      write(i, p, Vec3(d[0], d[1], d[2]));
      ++moved;
    }
    return moved;
  }));
}

void updateFollowers(const HairModel& model, const SolverConfig& config, const Pose& pose,
                     const Obstacles* obstacles, double dt_s, int threads, HairState* state) {
  const FollowerMap& f = model.followers;
  if (f.guide_strands <= 0) return;
  threads = std::max(1, std::min(threads, static_cast<int>(state->scratch.size())));
  detail::parallelFor(threads, detail::Schedule::kStatic, 0, f.guide_strands, [&](int g) {
    StrandScratch& scratch = state->scratch[detail::threadIndex()];
    const int begin = model.strandBegin(g), n = model.strandSize(g);
    exaggeratedRest(model, config.curl, g, &state->saturation[begin],
                    &state->guide_rest_head[begin]);
    Vec3* x = &state->guide_position_head[begin];
    for (int i = 0; i < n; ++i) x[i] = pose.applyInverse(state->position[begin + i]);
    Mat3* frames = scratch.frame.data();
    smoothedFrames(x, n, model.root_frame_head[g], model.beta_core[g], scratch.smooth_bend.data(),
                   frames);
    const Vec3* rest = &state->guide_rest_head[begin];
    for (int i = 0; i + 1 < n; ++i) {
      const Mat3 turn = frames[i] * f.guide_rest_frame[begin + i].transpose();
      setGuideEdgeCarry(turn, x[i] - turn * rest[i], x[i + 1] - turn * rest[i + 1],
                        (x[i + 1] - x[i]).norm() / model.rest_edge_m[begin + i],
                        &state->guide_edge_carry[begin + i]);
    }
  });
  const PlacementFrame frame(model, config, pose, obstacles, dt_s);
  const int followers = model.strandCount() - f.guide_strands;
  const int groups = (followers + kFollowerLanes - 1) / kFollowerLanes;
  detail::parallelFor(threads, detail::Schedule::kDynamic, 4, groups, [&](int group) {
    // The stepper's lane storage, free after the step, holds the group's columns.
    const FollowerColumns columns = carveFollowerColumns(&state->scratch[detail::threadIndex()]);
    const int first = group * kFollowerLanes;
    placeFollowers(frame, f.guide_strands + first, std::min(kFollowerLanes, followers - first),
                   columns, state);
  });
}

}  // namespace wet_curly_hair

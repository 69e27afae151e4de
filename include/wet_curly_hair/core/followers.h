// Guides and followers: simulate one strand in K (the guides), place the others (followers)
// after each step from their nearest guides in root space (docs/followers.md).
#pragma once

#include <string>
#include <vector>

#include "wet_curly_hair/core/config.h"
#include "wet_curly_hair/core/groom.h"
#include "wet_curly_hair/core/lane_math.h"
#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/obstacles.h"
#include "wet_curly_hair/core/state.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// Guides each follower is interpolated from.
constexpr int kFollowerGuides = 3;

/// Farthest-point sampling of `count` roots (head frame): the first is root 0, each next one the
/// root farthest from those already chosen (the lowest index on a tie). Deterministic; returns
/// the chosen indices in ascending order. count is clamped to [1, roots.size()].
std::vector<int> selectGuides(const Vec3List& roots, int count);

/// Root-space weights of a follower from the distances d[0] <= d[1] <= ... (m, `count` of them,
/// sorted) to its nearest guides: w[i] for i < min(count, kFollowerGuides), summing to 1.
/// Franke-Nielson's modified Shepard weights w_i ~ ((R - d_i) / (R d_i))^2 with R the distance of
/// the next guide (d[kFollowerGuides], or 2 d[count - 1] with fewer guides), so that a guide's
/// weight falls to 0 where it stops being one of the nearest: the weights are continuous over
/// the scalp. A follower on a guide's root (d[0] below 1e-9 m) copies that guide alone.
void followerWeights(const double* d, int count, double* w);

/// How buildFollowerModel chooses its ceil(N / K) guides (GroomConfig::guides).
enum class GuideChoice {
  kSampled,  ///< farthest-point sampling on the roots (selectGuides): "sampled"
  kFirst,    ///< the groom's first strands, in their order: "first"
};

/// The choice named by GroomConfig::guides ("first", else sampled: validated there).
GuideChoice guideChoice(const std::string& name);

/// Builds the model of a groom of which one strand in follow_ratio is simulated: ceil(N / K)
/// guides chosen by `choice`, the model's strands ordered guides first (FollowerMap::source_strand
/// gives each one's groom index), each follower's guides, weights and arc-length samples fixed
/// here. follow_ratio 1 is buildModel. False with a reason naming groom.follow_ratio or the field
/// buildModel refused; *model unchanged then.
bool buildFollowerModel(const Groom& groom, double linear_density_kg_per_m, int follow_ratio,
                        const HeadShape& head, const SolverConfig& config, HairModel* model,
                        std::string* why, GuideChoice choice = GuideChoice::kSampled);

/// The rest shape of strand s exaggerated toward its wet helix by its saturation `sigma` (one per
/// particle), head frame, into out[0 .. size). Each rest edge e turns toward the helix edge h of
/// eq. (6) (carried to the rest axis, FollowerMap::curl_turn) by b = k_w sigma / (k_w sigma +
/// k_b), the share of the curl spring in the two springs that pull the edge (spring mode, A10),
/// keeping its length; dry strands, or curl off, give the rest shape exactly.
void exaggeratedRest(const HairModel& model, const CurlConfig& curl, int s, const double* sigma,
                     Vec3* out);

/// The guide samples of one follower strand s, as updateFollowers places it: for each of its
/// particles i (global index), forEach(i, fn) calls fn(a, w, t) per guide that counts, with the
/// guide's weight w (the weights sum to 1) and the guide edge from particle a to a + 1 on which
/// the follower's normalized arc length falls, at fraction t. A sample stands for weight w (1 -
/// t) at a and w t at a + 1. The strand's weights and the arrays' addresses are read once, at
/// construction: read through the model at every particle, the compiled passes loaded them again
/// at every sample (docs/followers.md, measured).
class GuideSamples {
 public:
  GuideSamples(const HairModel& model, int s) {
    const FollowerMap& f = model.followers;
    const size_t k = static_cast<size_t>(s - f.guide_strands) * kFollowerGuides;
    for (int g = 0; g < kFollowerGuides; ++g) weight_[g] = f.weight[k + g];
    first_particle_ = static_cast<int>(model.strandBegin(f.guide_strands));
    index_ = f.sample_index.data();
    fraction_ = f.sample_fraction.data();
  }
  template <typename Fn>
  WCH_INLINE void forEach(int i, Fn fn) const {
    const size_t e0 = static_cast<size_t>(i - first_particle_) * kFollowerGuides;
    for (int g = 0; g < kFollowerGuides; ++g) {
      if (weight_[g] == 0.0) continue;
      fn(index_[e0 + g], weight_[g], fraction_[e0 + g]);
    }
  }

 private:
  double weight_[kFollowerGuides];
  int first_particle_;
  const uint32_t* index_;
  const double* fraction_;
};

/// cohesion.gather_at "guides", after the guides' display offsets (state->guide_clump_offset,
/// wet or dry guide particles alike): every wet follower particle's p^w = p plus the offsets
/// interpolated at it (GuideSamples), every dry one's p^w = p; the offsets also to
/// state->display_offset where config holds them between evaluations (refresh_period_s > 0).
/// An approximation: a particle's own offset points at its nearest neighbours, millimetres away,
/// which its guides' offsets do not know; measured, the followers' p^w differs from their own
/// sums' by about the offset itself, while the clump distance stays within a few %
/// (docs/followers.md). Returns the wet follower particles moved. No-op without followers.
int displayFollowersFromGuides(const HairModel& model, const CohesionConfig& config,
                               HairState* state, int threads);

/// Places every follower after a step, in the head frame (head_pose): the weighted sum over its
/// guides of the guide's point at the follower particle's normalized arc length plus the
/// follower's offset from that point on the exaggerated rest shapes, turned by the rotation of
/// the guide's frame there (edge frames of the curve smoothed over the core smoothing length,
/// current against rest); then pushed out of the head (collision offset, as the solver) and the
/// obstacles (world frame; null: none). Velocities are the change of position over dt_s (none when
/// dt_s is 0). The placement runs in single precision (followers.cpp, FollowerLane): positions,
/// lengths and clearances hold to float round-off. Allocates nothing. No-op without followers.
void updateFollowers(const HairModel& model, const SolverConfig& config, const Pose& head_pose,
                     const Obstacles* obstacles, double dt_s, int threads, HairState* state);

}  // namespace wet_curly_hair

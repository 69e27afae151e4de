// Measurements of the hair's shape used to reproduce the paper's comparisons (docs/paper.md):
// clump tightness, tangles, curl radius and pitch of the tips. The two neighbour measurements
// run on spatial hash grids whose cells are tied to the distance they look for, so their cost
// grows with the particles and the contacts found, not with the square of the strand count.
#pragma once

#include <cstdint>
#include <vector>

#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// Scratch of the measurements' spatial hash grids. Grown on first use to the largest input
/// seen, then reused: a measurement on inputs no larger than before allocates nothing.
struct MetricScratch {
  double cell_m = 0.0;
  /// Hash buckets: bucket b holds entries [bucket_start[b], bucket_start[b + 1]).
  std::vector<uint32_t> bucket_start;
  /// Per entry, in bucket order: the cell key (cells wrap every 2^21 cells per axis; the exact
  /// distance tests tell aliases apart), the item (particle or segment) and its strand.
  std::vector<uint64_t> entry_key;
  std::vector<uint32_t> entry_item;
  std::vector<uint32_t> entry_strand;
  std::vector<double> entry_x, entry_y, entry_z;  ///< particle grids: the particle's position.
  /// Segment grids, per segment (indexed by its root-side particle): its box grown by half the
  /// contact distance (min then max corner, 6 floats rounded outward) and its kind (none, in the
  /// grid, long); per entry a copy of its segment's box; long_segments: those spanning too many
  /// cells to enter, tested against every segment.
  std::vector<float> box, entry_box;
  std::vector<uint8_t> segment_kind;
  std::vector<uint32_t> long_segments;
  std::vector<double> nearest;     ///< clumpDistance: per particle, the distance found.
  std::vector<double> per_strand;  ///< lengthStats: per strand, 3 partial results.
};

/// Mean distance (m) from each wet particle's position in `points` (saturation > 0) to the
/// nearest point of another strand, searched within search_radius_m (farther, or a non-finite
/// position, counts as search_radius_m). Returns 0 when no particle is wet. Exact: the same
/// value, to the last bit, as the mean over wet particles of the all-pairs minimum, summed in
/// particle order (test_metrics). Nearest-neighbour search ring by ring on a grid of cells
/// about half an edge wide, stopping once no farther ring can hold anything nearer; any thread
/// count gives the same result. strand_stride k > 1 samples: the mean over the wet particles of
/// every k-th strand (strands 0, k, 2k, ...; their neighbours are searched among all strands).
double clumpDistance(const HairModel& model, const Vec3List& points,
                     const std::vector<double>& saturation, double search_radius_m,
                     MetricScratch* scratch, int threads = 1, int strand_stride = 1);

/// clumpDistance's per-particle values: appends to *out, in particle order, the distance of every
/// wet particle of the sampled strands (the values clumpDistance averages; one search serves
/// both).
void clumpDistanceSamples(const HairModel& model, const Vec3List& points,
                          const std::vector<double>& saturation, double search_radius_m,
                          MetricScratch* scratch, std::vector<double>* out, int threads = 1,
                          int strand_stride = 1);

/// Number of segment pairs of different strands closer than 2 * strand_radius_m (touching
/// strands: segmentDistance below the contact distance), from `points`. Exact: the same count as
/// the test of every pair (test_metrics). Each segment's box, grown by half the contact
/// distance, is entered in every grid cell it overlaps (cells about an edge wide); a pair is
/// tested in the one cell that holds the low corner of the overlap of its two boxes, so it is
/// counted once. Any thread count gives the same count.
///
/// strand_stride k > 1 estimates: with S strands of which m = ceil(S / k) are sampled (strands
/// 0, k, 2k, ...), and D the sum over the sampled strands of their touching pairs (a pair of two
/// sampled strands counted twice), returns round(S D / (2 m)), which is the exact count for
/// k = 1 and unbiased over the choice of sampled strands. Its cost is about 1/k of the exact
/// count's, which grows with the square of the strand count on one scalp (every strand touches
/// more of the others as they crowd).
int tangleCount(const HairModel& model, const Vec3List& points, double strand_radius_m,
                MetricScratch* scratch, int threads = 1, int strand_stride = 1);

/// Segment pairs of different strands that pass through each other between two frames (the
/// positions taken to move linearly from `before` to `after`): the pairs whose signed volume
/// changes sign while the two segments meet (crossed within kCrossingTolerance of their
/// lengths at the coplanar instant). A pair passing an even number of times in one frame is not
/// counted. Exact over the candidate pairs (swept boxes on the tangle count's segment grid);
/// any thread count gives the same count.
int64_t crossingCount(const HairModel& model, const Vec3List& before, const Vec3List& after,
                      MetricScratch* scratch, int threads = 1);
/// Relative distance at the coplanar instant under which two segments count as meeting.
constexpr double kCrossingTolerance = 1e-6;

/// Edge strain and strand extension of `points` in one pass over the edges, the strands shared
/// among `threads` threads.
struct LengthStats {
  double max_strain = 0.0;      ///< largest (L - L0) / L0 over the edges, and 0 (edgeStrain's max)
  double mean_strain = 0.0;     ///< mean |(L - L0) / L0| over the edges (edgeStrain's mean)
  double max_extension = 0.0;   ///< largest arc length / rest length - 1 over the strands
  double mean_extension = 0.0;  ///< its mean over the strands
};
/// edgeStrain (diagnostics.h) and the strands' arc-length extension. The maxima and the mean
/// extension are the same as summed in order to the last bit; the mean strain sums each strand's
/// edges, then the strands in order (the same value for any thread count, equal to edgeStrain's
/// up to rounding). Uses scratch->per_strand.
LengthStats lengthStats(const HairModel& model, const Vec3List& points, MetricScratch* scratch,
                        int threads = 1);

/// The groom's volume as a length: the mean signed distance of the non-root particles (finite
/// ones) from the head surface, m.
double meanHeadDistance(const HairModel& model, const Vec3List& points, const Pose& head_pose);

/// Deepest penetration (m, >= 0) of a non-root particle at `points` (world) into the head at
/// head_pose: maxHeadPenetration of diagnostics.h (equal up to rounding: the same distance
/// function, on four particles at a time in double lanes), the strands shared among `threads`
/// threads (the maximum is the same for any count).
double headPenetration(const HairModel& model, const Vec3List& points, const Pose& head_pose,
                       int threads = 1);

/// Curl radius and rise per turn (m) of a polyline from its discrete curvature kappa and torsion
/// tau: a helix has r = kappa / (kappa^2 + tau^2), pitch = 2 pi tau / (kappa^2 + tau^2).
struct CurlShape {
  double radius_m = 0.0;
  double pitch_m = 0.0;
};
/// Curl shape of strand s's tip third, from the mean discrete curvature and torsion over it
/// (0, 0 where the tip third is straight). False, and *out unchanged, when the strand is too
/// short for one sample of torsion there (fewer than 10 particles).
bool strandTipCurl(const HairModel& model, const Vec3List& points, int strand, CurlShape* out);
/// Mean over strands of strandTipCurl (the strands it leaves out are left out of the mean).
CurlShape tipCurlShape(const HairModel& model, const Vec3List& points);

/// Distance between segments [a0, a1] and [b0, b1] (m).
double segmentDistance(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1);

}  // namespace wet_curly_hair

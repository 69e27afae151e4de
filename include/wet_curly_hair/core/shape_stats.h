// Shape statistics that survive strands parting on a knife edge: where a strand passes an
// obstacle on one side in one run and on the other side in another, the particle-by-particle
// error between the runs stops meaning anything, but the distributions of tip height, tip curl
// radius and clump distance over the groom stay comparable. Per-strand and per-particle samples
// of one frame, and two distances between the distributions of two samples (docs/performance.md).
#pragma once

#include <vector>

#include "wet_curly_hair/core/metrics.h"
#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// Appends per strand the height of its tip above its root along the head frame's +z (up at
/// rest): (R^T (tip - root)).z with R the rotation of head_pose (head -> world). A strand
/// hanging straight down from an upright head gives minus its length.
void tipHeights(const HairModel& model, const Vec3List& points, const Pose& head_pose,
                std::vector<double>* out);

/// Samples of the groom's shape pooled over frames (or runs).
struct ShapeSamples {
  std::vector<double> tip_height_m;      ///< per strand and frame: tipHeights
  std::vector<double> curl_radius_m;     ///< per strand long enough and frame: strandTipCurl
  std::vector<double> clump_distance_m;  ///< per wet particle and frame: clumpDistanceSamples
};

/// Appends one frame's samples to *out: the tip heights and tip curl radii of `points`, and the
/// clump distance of its wet particles (saturation > 0) searched within clump_search_m.
void appendShapeSamples(const HairModel& model, const Vec3List& points,
                        const std::vector<double>& saturation, const Pose& head_pose,
                        double clump_search_m, MetricScratch* scratch, ShapeSamples* out,
                        int threads = 1);

/// How far apart the distributions of two samples are, in the samples' unit (m here).
struct SampleDistance {
  /// Wasserstein-1 (earth mover's) distance: the mean over u in (0, 1) of |Qa(u) - Qb(u)|, Qa
  /// and Qb the empirical quantile functions (exact for unequal sizes). A sample against
  /// itself shifted by d gives |d|; it is the mean distance each value has to move to turn one
  /// distribution into the other.
  double w1 = 0.0;
  /// Two-sample Kolmogorov-Smirnov statistic: the largest difference of the two empirical
  /// cumulative distributions, in [0, 1] (0: the same distribution, 1: disjoint ranges).
  double ks = 0.0;
  /// The spread of the second sample (the reference): the mean absolute deviation from its
  /// median, which is w1 between it and its median alone. w1 / spread_b < 1 means the first
  /// distribution is nearer the reference's than the reference's own median is.
  double spread_b = 0.0;
};
/// Distances between the distributions of samples a and b (b the reference). All NaN when
/// either sample is empty or holds a non-finite value (a run that blew up).
SampleDistance compareSamples(std::vector<double> a, std::vector<double> b);

/// compareSamples on each of the three shape samples, `reference` as b.
struct ShapeDistance {
  SampleDistance tip_height, curl_radius, clump_distance;
};
ShapeDistance compareShapes(const ShapeSamples& a, const ShapeSamples& reference);

}  // namespace wet_curly_hair

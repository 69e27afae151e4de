#include "wet_curly_hair/core/shape_stats.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>

namespace wet_curly_hair {

void tipHeights(const HairModel& model, const Vec3List& points, const Pose& head_pose,
                std::vector<double>* out) {
  const Quat to_head = head_pose.rotation.conjugate();
  for (int s = 0; s < model.strandCount(); ++s) {
    const int root = model.strandBegin(s), tip = root + model.strandSize(s) - 1;
    out->push_back((to_head * (points[tip] - points[root])).z());
  }
}

void appendShapeSamples(const HairModel& model, const Vec3List& points,
                        const std::vector<double>& saturation, const Pose& head_pose,
                        double clump_search_m, MetricScratch* scratch, ShapeSamples* out,
                        int threads) {
  tipHeights(model, points, head_pose, &out->tip_height_m);
  CurlShape curl;
  for (int s = 0; s < model.strandCount(); ++s)
    if (strandTipCurl(model, points, s, &curl)) out->curl_radius_m.push_back(curl.radius_m);
  clumpDistanceSamples(model, points, saturation, clump_search_m, scratch, &out->clump_distance_m,
                       threads);
}

SampleDistance compareSamples(std::vector<double> a, std::vector<double> b) {
  auto finite = [](const std::vector<double>& v) {
    return std::all_of(v.begin(), v.end(), [](double x) { return std::isfinite(x); });
  };
  if (a.empty() || b.empty() || !finite(a) || !finite(b)) {
    const double nan = std::numeric_limits<double>::quiet_NaN();
    return {nan, nan, nan};
  }
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  // Positions along u in (0, 1] in units of 1 / (n m), so that the quantile functions' steps
  // (at multiples of 1 / n and of 1 / m) are compared exactly.
  const int64_t n = static_cast<int64_t>(a.size()), m = static_cast<int64_t>(b.size());
  SampleDistance d;
  double w1 = 0.0;
  int64_t u = 0;
  for (int64_t i = 0, j = 0; i < n && j < m;) {
    const int64_t next = std::min((i + 1) * m, (j + 1) * n);
    w1 += double(next - u) * std::abs(a[i] - b[j]);
    u = next;
    if (next == (i + 1) * m) ++i;
    if (next == (j + 1) * n) ++j;
  }
  d.w1 = w1 / (double(n) * double(m));
  // KS: the cumulative distributions just after every value of either sample.
  int64_t largest = 0;
  for (int64_t i = 0, j = 0; i < n || j < m;) {
    const double x = j == m || (i < n && a[i] <= b[j]) ? a[i] : b[j];
    while (i < n && a[i] <= x) ++i;
    while (j < m && b[j] <= x) ++j;
    largest = std::max(largest, std::abs(i * m - j * n));
  }
  d.ks = double(largest) / (double(n) * double(m));
  const double median = m % 2 ? b[m / 2] : 0.5 * (b[m / 2 - 1] + b[m / 2]);
  double spread = 0.0;
  for (double x : b) spread += std::abs(x - median);
  d.spread_b = spread / double(m);
  return d;
}

ShapeDistance compareShapes(const ShapeSamples& a, const ShapeSamples& reference) {
  return {compareSamples(a.tip_height_m, reference.tip_height_m),
          compareSamples(a.curl_radius_m, reference.curl_radius_m),
          compareSamples(a.clump_distance_m, reference.clump_distance_m)};
}

}  // namespace wet_curly_hair

#include "wet_curly_hair/core/metrics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "parallel.h"
#include "wet_curly_hair/core/head_collider.h"
#include "wet_curly_hair/core/lane_math.h"

namespace wet_curly_hair {

namespace {

using detail::parallelFor;
using detail::parallelSum;
using detail::Schedule;

/// Cell coordinates beyond +-2^50 are clamped (a far point lands in a boundary cell, which only
/// makes the cell's distance bound lower than the point's: still a bound).
inline int64_t cellCoord(double x, double cell) {
  constexpr double kLimit = 1125899906842624.0;  // 2^50
  return static_cast<int64_t>(std::clamp(std::floor(x / cell), -kLimit, kLimit));
}

/// 21 bits per axis: cells 2^21 apart share a key (the exact distance tests tell them apart).
inline uint64_t cellKey(int64_t ix, int64_t iy, int64_t iz) {
  constexpr uint64_t m = (uint64_t{1} << 21) - 1;
  return (static_cast<uint64_t>(ix) & m) | ((static_cast<uint64_t>(iy) & m) << 21) |
         ((static_cast<uint64_t>(iz) & m) << 42);
}

inline uint32_t bucketOf(uint64_t key, uint32_t mask) {
  return static_cast<uint32_t>((key * 0x9E3779B97F4A7C15ull) >> 32) & mask;
}

/// Sizes the bucket table for `entries` entries (a power of two at least twice that) and the
/// entry arrays; grows only.
uint32_t prepareTable(size_t entries, bool positions, MetricScratch* g) {
  size_t table = 2;
  while (table < 2 * entries) table <<= 1;
  g->bucket_start.assign(table + 1, 0u);
  if (g->entry_key.size() < entries) {
    g->entry_key.resize(entries);
    g->entry_item.resize(entries);
    g->entry_strand.resize(entries);
  }
  if (positions && g->entry_x.size() < entries) {
    g->entry_x.resize(entries);
    g->entry_y.resize(entries);
    g->entry_z.resize(entries);
  }
  return static_cast<uint32_t>(table - 1);
}

/// Turns the per-bucket counts in bucket_start[b + 1] into offsets.
void prefixSum(MetricScratch* g) {
  for (size_t b = 1; b < g->bucket_start.size(); ++b) g->bucket_start[b] += g->bucket_start[b - 1];
}

/// Mean edge length over the finite edges (0 when there are none).
double meanEdge(const HairModel& model, const Vec3List& points) {
  double sum = 0.0;
  long count = 0;
  for (int s = 0; s < model.strandCount(); ++s) {
    const int end = model.strandBegin(s) + model.strandSize(s);
    for (int i = model.strandBegin(s); i + 1 < end; ++i) {
      const double l = (points[i + 1] - points[i]).norm();
      if (std::isfinite(l)) sum += l, ++count;
    }
  }
  return count ? sum / count : 0.0;
}

/// Enters every finite particle in the grid (cell size g->cell_m), with its position.
void buildParticleGrid(const HairModel& model, const Vec3List& points, MetricScratch* g) {
  const uint32_t mask = prepareTable(points.size(), true, g);
  const double c = g->cell_m;
  auto keyOf = [c](const Vec3& x) {
    return cellKey(cellCoord(x.x(), c), cellCoord(x.y(), c), cellCoord(x.z(), c));
  };
  for (const Vec3& x : points)
    if (x.allFinite()) ++g->bucket_start[bucketOf(keyOf(x), mask) + 1];
  prefixSum(g);
  for (int s = 0; s < model.strandCount(); ++s) {
    for (int i = model.strandBegin(s); i < model.strandBegin(s) + model.strandSize(s); ++i) {
      const Vec3& x = points[i];
      if (!x.allFinite()) continue;
      const uint64_t key = keyOf(x);
      const uint32_t e = g->bucket_start[bucketOf(key, mask)]++;
      g->entry_key[e] = key;
      g->entry_item[e] = static_cast<uint32_t>(i);
      g->entry_strand[e] = static_cast<uint32_t>(s);
      g->entry_x[e] = x.x();
      g->entry_y[e] = x.y();
      g->entry_z[e] = x.z();
    }
  }
  // The scatter advanced every bucket's start to the next one's: shift back.
  for (size_t b = g->bucket_start.size() - 1; b > 0; --b)
    g->bucket_start[b] = g->bucket_start[b - 1];
  g->bucket_start[0] = 0;
}

/// Squared distance from x to the nearest point of another strand than `strand`, or r2max when
/// none is nearer: the cells ring by ring (Chebyshev distance k from x's cell), skipping cells
/// wholly at or beyond the best so far, until no farther ring can hold anything nearer.
double nearestOtherStrand2(const MetricScratch& g, const Vec3& x, uint32_t strand, double r2max) {
  const double c = g.cell_m;
  const uint32_t mask = static_cast<uint32_t>(g.bucket_start.size() - 2);
  const int64_t cx = cellCoord(x.x(), c), cy = cellCoord(x.y(), c), cz = cellCoord(x.z(), c);
  // Distance bounds from cell edges carry the rounding of x / c: shrink them by far more.
  const double slack = 1e-9 * (c + x.cwiseAbs().maxCoeff());
  // Distance from x to the slab of cells at offset d along one axis (0 for its own).
  auto gap = [c, slack](double xc, int64_t cell, int64_t d) {
    if (d == 0) return 0.0;
    const double g = d > 0 ? double(cell + d) * c - xc : xc - double(cell + d + 1) * c;
    return std::max(0.0, g - slack);
  };
  double best2 = r2max;
  for (int64_t k = 0;; ++k) {
    // Every cell of ring k or beyond is at least (k - 1) cells away.
    const double bound = double(k - 1) * c - slack;
    if (k >= 1 && bound > 0.0 && best2 <= bound * bound) break;
    for (int64_t dz = -k; dz <= k; ++dz) {
      const double gz = gap(x.z(), cz, dz);
      if (gz * gz >= best2) continue;
      for (int64_t dy = -k; dy <= k; ++dy) {
        const double gy = gap(x.y(), cy, dy);
        if (gz * gz + gy * gy >= best2) continue;
        const bool face = std::abs(dz) == k || std::abs(dy) == k;
        for (int64_t dx = -k; dx <= k; dx += (face || k == 0) ? 1 : 2 * k) {
          const double gx = gap(x.x(), cx, dx);
          if (gz * gz + gy * gy + gx * gx >= best2) continue;
          const uint64_t key = cellKey(cx + dx, cy + dy, cz + dz);
          const uint32_t b = bucketOf(key, mask);
          for (uint32_t e = g.bucket_start[b]; e < g.bucket_start[b + 1]; ++e) {
            if (g.entry_key[e] != key || g.entry_strand[e] == strand) continue;
            const double ex = g.entry_x[e] - x.x(), ey = g.entry_y[e] - x.y(),
                         ez = g.entry_z[e] - x.z();
            const double r2 = ex * ex + ey * ey + ez * ez;
            if (r2 < best2) best2 = r2;
          }
        }
      }
    }
  }
  return best2;
}

}  // namespace

namespace {

/// scratch->nearest[i]: the distance of every wet particle i of the sampled strands (every
/// stride-th) to the nearest point of another strand, search_radius_m when farther or when the
/// particle is not finite.
void nearestOtherStrands(const HairModel& model, const Vec3List& points,
                         const std::vector<double>& saturation, double radius, MetricScratch* g,
                         int threads, int stride) {
  // Cells of half an edge: in a dense groom the nearest other strand is a ring or two away; at
  // most 16 rings out to the search radius where the hair is sparse.
  g->cell_m = std::max(0.5 * meanEdge(model, points), radius / 16.0);
  if (!(g->cell_m > 0.0)) g->cell_m = radius > 0.0 ? radius : 1.0;
  buildParticleGrid(model, points, g);
  if (g->nearest.size() < points.size()) g->nearest.resize(points.size());
  const double r2max = radius * radius;
  const int sampled = (model.strandCount() + stride - 1) / stride;
  parallelFor(threads, Schedule::kDynamic, 64, sampled, [&](int k) {
    const int s = k * stride;
    for (int i = model.strandBegin(s); i < model.strandBegin(s) + model.strandSize(s); ++i) {
      if (saturation[i] <= 0.0) continue;
      const double best2 = points[i].allFinite()
                               ? nearestOtherStrand2(*g, points[i], static_cast<uint32_t>(s), r2max)
                               : r2max;
      g->nearest[i] = std::sqrt(best2);
    }
  });
}

}  // namespace

double clumpDistance(const HairModel& model, const Vec3List& points,
                     const std::vector<double>& saturation, double radius, MetricScratch* g,
                     int threads, int strand_stride) {
  const int stride = std::max(1, strand_stride);
  nearestOtherStrands(model, points, saturation, radius, g, threads, stride);
  // Summed in particle order: the same sum for any thread count.
  double sum = 0.0;
  long count = 0;
  for (int s = 0; s < model.strandCount(); s += stride) {
    for (int i = model.strandBegin(s); i < model.strandBegin(s) + model.strandSize(s); ++i) {
      if (saturation[i] <= 0.0) continue;
      sum += g->nearest[i];
      ++count;
    }
  }
  return count ? sum / count : 0.0;
}

void clumpDistanceSamples(const HairModel& model, const Vec3List& points,
                          const std::vector<double>& saturation, double radius, MetricScratch* g,
                          std::vector<double>* out, int threads, int strand_stride) {
  const int stride = std::max(1, strand_stride);
  nearestOtherStrands(model, points, saturation, radius, g, threads, stride);
  for (int s = 0; s < model.strandCount(); s += stride)
    for (int i = model.strandBegin(s); i < model.strandBegin(s) + model.strandSize(s); ++i)
      if (saturation[i] > 0.0) out->push_back(g->nearest[i]);
}

double segmentDistance(const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1) {
  // Closest points of two segments (clamped parameters; Ericson, Real-Time Collision Detection).
  const Vec3 d1 = p1 - p0, d2 = q1 - q0, r = p0 - q0;
  const double a = d1.squaredNorm(), e = d2.squaredNorm(), f = d2.dot(r);
  double s = 0.0, t = 0.0;
  if (a <= 1e-24 && e <= 1e-24) return r.norm();
  if (a <= 1e-24) {
    t = std::clamp(f / e, 0.0, 1.0);
  } else {
    const double c = d1.dot(r);
    if (e <= 1e-24) {
      s = std::clamp(-c / a, 0.0, 1.0);
    } else {
      const double b = d1.dot(d2), denom = a * e - b * b;
      s = denom > 1e-24 ? std::clamp((b * f - c * e) / denom, 0.0, 1.0) : 0.0;
      t = (b * s + f) / e;
      if (t < 0.0) {
        t = 0.0;
        s = std::clamp(-c / a, 0.0, 1.0);
      } else if (t > 1.0) {
        t = 1.0;
        s = std::clamp((b - c) / a, 0.0, 1.0);
      }
    }
  }
  return ((p0 + s * d1) - (q0 + t * d2)).norm();
}

namespace {

/// A segment whose grown box spans more cells than this along an axis is tested against every
/// segment instead of being entered in the grid (a blown-up edge must not flood the grid).
constexpr int64_t kMaxSpanCells = 16;

enum SegmentKind : uint8_t { kNoSegment = 0, kGridSegment = 1, kLongSegment = 2 };

/// The float nearest x on its side (boxes in float stay boxes around the double ones; the
/// pair tests read 24 bytes per entry, sequentially).
inline float floatBelow(double x) {
  float f = static_cast<float>(x);
  return static_cast<double>(f) > x ? std::nextafter(f, -std::numeric_limits<float>::infinity())
                                    : f;
}
inline float floatAbove(double x) {
  float f = static_cast<float>(x);
  return static_cast<double>(f) < x ? std::nextafter(f, std::numeric_limits<float>::infinity()) : f;
}

/// Calls fn(key) for every cell the box (min corner b[0..2], max corner b[3..5]) overlaps.
template <typename Fn>
void forEachBoxCell(const float* b, double c, Fn fn) {
  const int64_t x0 = cellCoord(b[0], c), x1 = cellCoord(b[3], c);
  const int64_t y0 = cellCoord(b[1], c), y1 = cellCoord(b[4], c);
  const int64_t z0 = cellCoord(b[2], c), z1 = cellCoord(b[5], c);
  for (int64_t z = z0; z <= z1; ++z)
    for (int64_t y = y0; y <= y1; ++y)
      for (int64_t x = x0; x <= x1; ++x) fn(cellKey(x, y, z));
}

/// Each segment's box grown by `grow` (MetricScratch::box, indexed by its root-side particle)
/// and its kind: no segment (a tip, or a non-finite end: never touches anything), entered in
/// the grid, or long.
void segmentBoxes(const HairModel& model, const Vec3List& points, double grow, double c,
                  MetricScratch* g, const Vec3List* before = nullptr) {
  const size_t n = points.size();
  if (g->box.size() < 6 * n) g->box.resize(6 * n);
  g->segment_kind.assign(n, kNoSegment);
  g->long_segments.clear();
  for (int s = 0; s < model.strandCount(); ++s) {
    const int end = model.strandBegin(s) + model.strandSize(s);
    for (int i = model.strandBegin(s); i + 1 < end; ++i) {
      if (!points[i].allFinite() || !points[i + 1].allFinite()) continue;
      float* b = &g->box[6 * static_cast<size_t>(i)];
      Vec3 lo = points[i].cwiseMin(points[i + 1]), hi = points[i].cwiseMax(points[i + 1]);
      if (before) {  // the box swept from `before` to `points`
        const Vec3List& q = *before;
        if (!q[i].allFinite() || !q[i + 1].allFinite()) continue;
        lo = lo.cwiseMin(q[i]).cwiseMin(q[i + 1]);
        hi = hi.cwiseMax(q[i]).cwiseMax(q[i + 1]);
      }
      bool long_segment = false;
      for (int a = 0; a < 3; ++a) {
        b[a] = floatBelow(lo[a] - grow);
        b[3 + a] = floatAbove(hi[a] + grow);
        long_segment = long_segment || cellCoord(b[3 + a], c) - cellCoord(b[a], c) >= kMaxSpanCells;
      }
      g->segment_kind[i] = long_segment ? kLongSegment : kGridSegment;
      if (long_segment) g->long_segments.push_back(static_cast<uint32_t>(i));
    }
  }
}

/// Cells the box of segment i overlaps.
inline size_t boxCells(const float* b, double c) {
  size_t cells = 1;
  for (int a = 0; a < 3; ++a)
    cells *= static_cast<size_t>(cellCoord(b[3 + a], c) - cellCoord(b[a], c) + 1);
  return cells;
}

/// Enters every grid segment of the strands s with s % stride == 0 in each cell its box
/// overlaps.
void buildSegmentGrid(const HairModel& model, int stride, MetricScratch* g) {
  const double c = g->cell_m;
  size_t entries = 0;
  for (int s = 0; s < model.strandCount(); s += stride)
    for (int i = model.strandBegin(s); i + 1 < model.strandBegin(s) + model.strandSize(s); ++i)
      if (g->segment_kind[i] == kGridSegment) entries += boxCells(&g->box[6 * size_t(i)], c);
  const uint32_t mask = prepareTable(entries, false, g);
  if (g->entry_box.size() < 6 * entries) g->entry_box.resize(6 * entries);
  for (int pass = 0; pass < 2; ++pass) {
    for (int s = 0; s < model.strandCount(); s += stride) {
      const int end = model.strandBegin(s) + model.strandSize(s);
      for (int i = model.strandBegin(s); i + 1 < end; ++i) {
        if (g->segment_kind[i] != kGridSegment) continue;
        const float* box = &g->box[6 * static_cast<size_t>(i)];
        forEachBoxCell(box, c, [&](uint64_t key) {
          const uint32_t b = bucketOf(key, mask);
          if (pass == 0) {
            ++g->bucket_start[b + 1];
            return;
          }
          const uint32_t e = g->bucket_start[b]++;
          g->entry_key[e] = key;
          g->entry_item[e] = static_cast<uint32_t>(i);
          g->entry_strand[e] = static_cast<uint32_t>(s);
          std::copy(box, box + 6, &g->entry_box[6 * static_cast<size_t>(e)]);
        });
      }
    }
    if (pass == 0) prefixSum(g);
  }
  // The scatter advanced every bucket's start to the next one's: shift back.
  for (size_t b = g->bucket_start.size() - 1; b > 0; --b)
    g->bucket_start[b] = g->bucket_start[b - 1];
  g->bucket_start[0] = 0;
}

inline bool boxesOverlap(const float* a, const float* b) {
  return a[0] <= b[3] && b[0] <= a[3] && a[1] <= b[4] && b[1] <= a[4] && a[2] <= b[5] &&
         b[2] <= a[5];
}

/// The key of the cell holding the low corner of the overlap of two boxes: both boxes overlap
/// that cell, so a pair tested only there is tested once.
inline uint64_t overlapCornerKey(const float* a, const float* b, double c) {
  return cellKey(cellCoord(std::max(a[0], b[0]), c), cellCoord(std::max(a[1], b[1]), c),
                 cellCoord(std::max(a[2], b[2]), c));
}

/// Whether segments i and j (root-side particles, different strands) touch. The segment of the
/// lower index goes first, as in the test of every pair, so rounding cannot make them differ.
inline bool touching(const Vec3List& p, uint32_t i, uint32_t j, double contact) {
  if (j < i) std::swap(i, j);
  return segmentDistance(p[i], p[i + 1], p[j], p[j + 1]) < contact;
}

/// Pairs with a long segment for which pair(i, j) holds (each long segment against every segment
/// of another strand, a pair of long segments once), each counted weight(strand) +
/// weight(other strand) times.
template <typename Pair, typename Weight>
int64_t longSegmentPairs(const HairModel& model, Pair pair, const MetricScratch& g, Weight weight) {
  int64_t count = 0;
  for (uint32_t a : g.long_segments) {
    const float* ba = &g.box[6 * static_cast<size_t>(a)];
    int sa = 0;
    while (model.strandBegin(sa) + model.strandSize(sa) <= static_cast<int>(a)) ++sa;
    for (int s = 0; s < model.strandCount(); ++s) {
      if (s == sa) continue;
      const int begin = model.strandBegin(s), end = begin + model.strandSize(s);
      for (int j = begin; j + 1 < end; ++j) {
        const uint8_t kind = g.segment_kind[j];
        if (kind == kNoSegment || (kind == kLongSegment && static_cast<uint32_t>(j) < a)) continue;
        if (boxesOverlap(ba, &g.box[6 * static_cast<size_t>(j)]) &&
            pair(a, static_cast<uint32_t>(j)))
          count += weight(sa) + weight(s);
      }
    }
  }
  return count;
}

/// Every pair of grid segments for which pair(i, j) holds, once: the pairs within each bucket.
template <typename Pair>
int64_t gridPairs(Pair pair, const MetricScratch& g, int threads) {
  const double c = g.cell_m;
  const int64_t buckets = static_cast<int64_t>(g.bucket_start.size()) - 1;
  return parallelSum(threads, 256, buckets, [&](int64_t b) {
    int64_t count = 0;
    const uint32_t lo = g.bucket_start[b], hi = g.bucket_start[b + 1];
    for (uint32_t e = lo; e < hi; ++e) {
      const uint64_t key = g.entry_key[e];
      const uint32_t i = g.entry_item[e], strand = g.entry_strand[e];
      const float* bi = &g.entry_box[6 * static_cast<size_t>(e)];
      for (uint32_t f = e + 1; f < hi; ++f) {
        const float* bj = &g.entry_box[6 * static_cast<size_t>(f)];
        if (!boxesOverlap(bi, bj) || g.entry_key[f] != key || g.entry_strand[f] == strand) continue;
        if (overlapCornerKey(bi, bj, c) == key && pair(i, g.entry_item[f])) ++count;
      }
    }
    return count;
  });
}

/// Sum over the grid's (sampled) segments of the touching grid segments of other strands: every
/// grid segment looks in the cells of its box.
int64_t sampledGridPairs(const HairModel& model, const Vec3List& points, double contact,
                         const MetricScratch& g, int threads) {
  const double c = g.cell_m;
  const uint32_t mask = static_cast<uint32_t>(g.bucket_start.size() - 2);
  return parallelSum(threads, 16, model.strandCount(), [&](int s) {
    int64_t count = 0;
    const int end = model.strandBegin(s) + model.strandSize(s);
    for (int j = model.strandBegin(s); j + 1 < end; ++j) {
      if (g.segment_kind[j] != kGridSegment) continue;
      const float* bj = &g.box[6 * static_cast<size_t>(j)];
      forEachBoxCell(bj, c, [&](uint64_t key) {
        const uint32_t b = bucketOf(key, mask);
        for (uint32_t e = g.bucket_start[b]; e < g.bucket_start[b + 1]; ++e) {
          const float* bi = &g.entry_box[6 * static_cast<size_t>(e)];
          if (!boxesOverlap(bi, bj) || g.entry_key[e] != key ||
              g.entry_strand[e] == static_cast<uint32_t>(s))
            continue;
          if (overlapCornerKey(bi, bj, c) == key &&
              touching(points, g.entry_item[e], static_cast<uint32_t>(j), contact))
            ++count;
        }
      });
    }
    return count;
  });
}

}  // namespace

int tangleCount(const HairModel& model, const Vec3List& points, double strand_radius,
                MetricScratch* g, int threads, int strand_stride) {
  const double contact = 2.0 * strand_radius;
  // Two segments closer than the contact distance have boxes grown by half of it that overlap
  // (grown a little more, so that rounding never hides a pair: the test that counts is exact).
  const double grow = 0.5 * contact * (1.0 + 1e-9) + 1e-15;
  // Cells about an edge wide: a segment's box overlaps a few, and a few boxes overlap each.
  g->cell_m = std::max(meanEdge(model, points), 2.0 * grow);
  segmentBoxes(model, points, grow, g->cell_m, g);
  const int stride = std::max(1, strand_stride);
  buildSegmentGrid(model, stride, g);
  auto touches = [&](uint32_t i, uint32_t j) { return touching(points, i, j, contact); };
  if (stride == 1)
    return static_cast<int>(gridPairs(touches, *g, threads) +
                            longSegmentPairs(model, touches, *g, [](int) { return 1; }) / 2);
  // Sum of the sampled strands' touching pairs (a pair of two sampled strands twice), scaled by
  // strands / (2 sampled strands).
  const int strands = model.strandCount();
  const int sampled = (strands + stride - 1) / stride;
  const int64_t degrees =
      sampledGridPairs(model, points, contact, *g, threads) +
      longSegmentPairs(model, touches, *g, [stride](int s) { return s % stride == 0; });
  return static_cast<int>(std::lround(double(strands) * double(degrees) / (2.0 * sampled)));
}

namespace {

/// Whether segments i and j (root-side particles, different strands), moving linearly from
/// `before` to `after`, pass through each other: the signed volume (a1 - a0) x (b1 - b0) .
/// (b0 - a0), cubic in time, changes sign, and where it vanishes (bisection) the now coplanar
/// segments meet. The lower index goes first, so the answer does not depend on the order.
bool crossed(const Vec3List& before, const Vec3List& after, uint32_t i, uint32_t j) {
  if (j < i) std::swap(i, j);
  auto at = [&](double t, uint32_t k) { return Vec3(before[k] + t * (after[k] - before[k])); };
  auto volume = [&](double t) {
    const Vec3 a0 = at(t, i), b0 = at(t, j);
    return (at(t, i + 1) - a0).cross(at(t, j + 1) - b0).dot(b0 - a0);
  };
  const double v0 = volume(0.0), v1 = volume(1.0);
  if (!(v0 * v1 < 0.0)) return false;
  double lo = 0.0, hi = 1.0, vlo = v0;
  for (int k = 0; k < 60; ++k) {
    const double mid = 0.5 * (lo + hi), vm = volume(mid);
    if (vm == 0.0) lo = hi = mid;
    if (lo == hi) break;
    if ((vm < 0.0) == (vlo < 0.0)) {
      lo = mid;
      vlo = vm;
    } else {
      hi = mid;
    }
  }
  const double t = 0.5 * (lo + hi);
  const Vec3 a0 = at(t, i), a1 = at(t, i + 1), b0 = at(t, j), b1 = at(t, j + 1);
  // Coplanar to the bisection's precision: they meet when their distance is round-off small.
  const double tolerance = kCrossingTolerance * ((a1 - a0).norm() + (b1 - b0).norm());
  return segmentDistance(a0, a1, b0, b1) <= tolerance;
}

}  // namespace

int64_t crossingCount(const HairModel& model, const Vec3List& before, const Vec3List& after,
                      MetricScratch* g, int threads) {
  // Boxes swept over the frame, grown a little so that rounding never hides a pair.
  const double c = meanEdge(model, after);
  g->cell_m = c > 0.0 ? c : 1.0;
  segmentBoxes(model, after, 1e-9 * g->cell_m, g->cell_m, g, &before);
  buildSegmentGrid(model, 1, g);
  auto pass = [&](uint32_t i, uint32_t j) { return crossed(before, after, i, j); };
  return gridPairs(pass, *g, threads) +
         longSegmentPairs(model, pass, *g, [](int) { return 1; }) / 2;
}

LengthStats lengthStats(const HairModel& model, const Vec3List& points, MetricScratch* scratch,
                        int threads) {
  const int strands = model.strandCount();
  std::vector<double>& part = scratch->per_strand;
  if (part.size() < 3 * static_cast<size_t>(strands)) part.resize(3 * strands);
  parallelFor(threads, Schedule::kStatic, 0, strands, [&](int s) {
    const int begin = model.strandBegin(s), end = begin + model.strandSize(s);
    double max_strain = 0.0, abs_sum = 0.0, arc = 0.0;
    for (int i = begin; i + 1 < end; ++i) {
      const double l = (points[i + 1] - points[i]).norm();
      const double strain = l / model.rest_edge_m[i] - 1.0;
      max_strain = std::max(max_strain, strain);
      abs_sum += std::abs(strain);
      arc += l;
    }
    part[3 * s] = max_strain;
    part[3 * s + 1] = abs_sum;
    part[3 * s + 2] = arc / model.strand_length_m[s] - 1.0;
  });
  LengthStats out;
  out.max_extension = -std::numeric_limits<double>::infinity();
  double abs_sum = 0.0, ext_sum = 0.0;
  long edges = 0;
  for (int s = 0; s < strands; ++s) {
    out.max_strain = std::max(out.max_strain, part[3 * s]);
    abs_sum += part[3 * s + 1];
    out.max_extension = std::max(out.max_extension, part[3 * s + 2]);
    ext_sum += part[3 * s + 2];
    edges += std::max(0, model.strandSize(s) - 1);
  }
  out.mean_strain = edges ? abs_sum / edges : 0.0;
  out.mean_extension = strands ? ext_sum / strands : 0.0;
  return out;
}

double meanHeadDistance(const HairModel& model, const Vec3List& points, const Pose& head_pose) {
  double sum = 0.0;
  long count = 0;
  Vec3 normal;
  for (int s = 0; s < model.strandCount(); ++s) {
    for (int i = model.strandBegin(s) + 1; i < model.strandBegin(s) + model.strandSize(s); ++i) {
      if (!points[i].allFinite()) continue;
      sum += model.head.distance(head_pose.applyInverse(points[i]), &normal);
      ++count;
    }
  }
  return count ? sum / count : 0.0;
}

double headPenetration(const HairModel& model, const Vec3List& points, const Pose& head_pose,
                       int threads) {
  // Four particles at a time in double lanes (the distance is a handful of divisions and square
  // roots per particle): into the head frame by R^T (x - t), then HeadShape::distance.
  using S = LaneDouble4;
  constexpr int kLanes = 4;
  const Mat3 rt = head_pose.rotation.conjugate().toRotationMatrix();
  M33<S> to_head;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) to_head.m[r][c] = splat<S>(rt(r, c));
  const V3<S> t = splat3<S>(head_pose.translation);
  auto strandWorst = [&](int s) {
    const int begin = model.strandBegin(s) + 1, end = model.strandBegin(s) + model.strandSize(s);
    double worst = 0.0;
    for (int i = begin; i < end; i += kLanes) {
      V3<S> x;
      for (int l = 0; l < kLanes; ++l)  // a short last block repeats its last particle
        setLane(&x, l, points[std::min(i + l, end - 1)]);
      V3<S> n;
      const S d = model.head.distance(to_head * (x - t), &n);
      for (int l = 0; l < kLanes; ++l) worst = std::max(worst, -d[l]);
    }
    return worst;
  };
  double worst = 0.0;
  const int strands = model.strandCount();
  if (threads <= 1) {  // a plain loop: no OpenMP team to make
    for (int s = 0; s < strands; ++s) worst = std::max(worst, strandWorst(s));
    return worst;
  }
#pragma omp parallel for num_threads(threads) schedule(static) reduction(max : worst)
  for (int s = 0; s < strands; ++s) worst = std::max(worst, strandWorst(s));
  return worst;
}

bool strandTipCurl(const HairModel& model, const Vec3List& points, int s, CurlShape* out) {
  const int begin = model.strandBegin(s), n = model.strandSize(s);
  if (n < 5) return false;
  double kappa_sum = 0.0, tau_sum = 0.0;
  int samples = 0;
  for (int i = begin + (2 * n) / 3; i + 3 < begin + n; ++i) {
    const Vec3 e0 = points[i + 1] - points[i], e1 = points[i + 2] - points[i + 1],
               e2 = points[i + 3] - points[i + 2];
    const double l = (e0.norm() + e1.norm() + e2.norm()) / 3.0;
    const Vec3 b0 = e0.cross(e1), b1 = e1.cross(e2);
    if (b0.norm() < 1e-15 || b1.norm() < 1e-15 || l <= 0.0) {
      ++samples;  // straight there: zero curvature
      continue;
    }
    const double turn = std::atan2(b0.norm(), e0.dot(e1));  // angle between edges
    const double twist = std::atan2(b0.cross(b1).dot(e1.normalized()), b0.dot(b1));
    kappa_sum += 2.0 * std::sin(0.5 * turn) / l;  // circle through three points: exact
    tau_sum += twist / l;
    ++samples;
  }
  if (samples == 0) return false;
  const double kappa = kappa_sum / samples, tau = tau_sum / samples;
  const double k2 = kappa * kappa + tau * tau;
  *out = CurlShape();
  if (k2 > 0.0) {
    out->radius_m = kappa / k2;
    out->pitch_m = 2.0 * M_PI * std::abs(tau) / k2;
  }
  return true;
}

CurlShape tipCurlShape(const HairModel& model, const Vec3List& points) {
  CurlShape out, strand;
  int strands = 0;
  for (int s = 0; s < model.strandCount(); ++s) {
    if (!strandTipCurl(model, points, s, &strand)) continue;
    out.radius_m += strand.radius_m;
    out.pitch_m += strand.pitch_m;
    ++strands;
  }
  if (strands) {
    out.radius_m /= strands;
    out.pitch_m /= strands;
  }
  return out;
}

}  // namespace wet_curly_hair

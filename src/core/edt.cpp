#include "wet_curly_hair/core/edt.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <new>
#include <sstream>

#ifdef _OPENMP
#include <omp.h>
#endif
#if defined(__AVX__) || defined(__SSE2__)
#include <immintrin.h>
#endif

namespace wet_curly_hair {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

/// Lines of the y and z passes are gathered this many at a time (consecutive x), so that every
/// strided read and write moves kBlock contiguous floats.
constexpr int kBlock = 16;

/// Loops are scheduled dynamically in small chunks: each line is computed the same way whichever
/// thread takes it, and a thread that loses its core to another process delays the pass by one
/// chunk only. Passes over fewer cells than this run on one thread: forking costs more than it
/// saves, and far more when another process holds a core (the team waits for a descheduled thread).
constexpr int64_t kMinParallelCells = int64_t{1} << 16;

int maxThreads() {
#ifdef _OPENMP
  return std::max(1, omp_get_max_threads());
#else
  return 1;
#endif
}

int threadId() {
#ifdef _OPENMP
  return omp_get_thread_num();
#else
  return 0;
#endif
}

/// Per-thread scratch for the passes, allocated once per transform (outside the parallel
/// regions, so an allocation failure is an exception we can catch rather than a terminate
/// inside OpenMP).
struct LineScratch {
  std::vector<float> block;  // kBlock gathered lines of length n, line after line.
  std::vector<double> g;     // f[v] + v^2 of the envelope parabolas, n.
  std::vector<double> zn;    // left boundary of parabola k: zn[k] / zd[k] (zd > 0), n.
  std::vector<double> zd;
  std::vector<float> fv;  // f[v] of the envelope parabolas, n.
  std::vector<float> v;   // envelope parabola apexes (integers, as floats), n.
  void resize(int n) {
    block.assign(static_cast<size_t>(kBlock) * n, 0.0f);
    g.assign(n, 0.0);
    zn.assign(n, 0.0);
    zd.assign(n, 0.0);
    fv.assign(n, 0.0f);
    v.assign(n, 0.0f);
  }
};

std::vector<LineScratch> makeScratch(int n) {
  std::vector<LineScratch> s(maxThreads());
  for (LineScratch& t : s) t.resize(n);
  return s;
}

/// Keeps the squared distance as it is.
struct Squared {
  float operator()(float d2) const { return d2; }
};

/// 1-D lower envelope (Felzenszwalb-Huttenlocher): d[q] = out(min_p f[p] + (q - p)^2) over the
/// n samples of f; +infinity samples are skipped, and a line without a finite sample gives
/// out(+infinity) everywhere. d may alias f (f is read completely before d is written).
///
/// The parabola boundaries are kept as fractions and compared by cross-multiplication in
/// double: no division on the loop-carried path (it was the latency bottleneck), and exact for
/// integer inputs (products stay below 2^53). The output is written parabola by parabola, so
/// that the inner loop vectorises.
template <class Out>
void envelope1d(const float* f, int n, float* d, LineScratch* s, Out out) {
  float* v = s->v.data();
  float* fv = s->fv.data();
  double* g = s->g.data();
  double* zn = s->zn.data();
  double* zd = s->zd.data();
  int k = -1;
  for (int q = 0; q < n; ++q) {
    const float fq = f[q];
    if (fq == kInf) continue;
    const double qd = q;
    const double gq = static_cast<double>(fq) + qd * qd;
    // Pop parabola k while the new one takes over at or before its left boundary:
    // (gq - g[k]) / (2 (q - v[k])) <= zn[k] / zd[k]. Parabola 0 starts at -infinity.
    while (k > 0 && (gq - g[k]) * zd[k] <= zn[k] * (2.0 * (qd - v[k]))) --k;
    if (k >= 0) {
      zn[k + 1] = gq - g[k];
      zd[k + 1] = 2.0 * (qd - v[k]);
    }
    ++k;
    v[k] = static_cast<float>(q);
    g[k] = gq;
    fv[k] = fq;
  }
  if (k < 0) {
    const float inf = out(kInf);
    std::fill(d, d + n, inf);
    return;
  }
  // Parabola j covers the samples zn[j] / zd[j] < q <= zn[j + 1] / zd[j + 1]. The floor of the
  // double quotient is exact: a quotient of integers below 2^50 with denominator below 2^26 is
  // either an integer or at least 2^-26 away from one, far more than its rounding error.
  const double last = n - 1;
  int q = 0;
  for (int j = 0; j <= k && q < n; ++j) {
    const int q_end =
        j == k
            ? n - 1
            : static_cast<int>(std::max(-1.0, std::min(std::floor(zn[j + 1] / zd[j + 1]), last)));
    const float vj = v[j];
    const float fj = fv[j];
    for (; q <= q_end; ++q) {
      const float dq = static_cast<float>(q) - vj;
      d[q] = out(dq * dq + fj);
    }
  }
}

/// Pass along contiguous rows of length n (the x pass): row r = 0 .. n_rows - 1 starts at
/// grid + r * n. If row_mask is given, only rows with row_mask[r] != 0 are transformed.
void contiguousPass(float* grid, int n, int64_t n_rows, const uint8_t* row_mask,
                    std::vector<LineScratch>* scratch) {
#pragma omp parallel for schedule(dynamic, 32) if (n_rows * n >= kMinParallelCells)
  for (int64_t row = 0; row < n_rows; ++row) {
    if (row_mask && !row_mask[row]) continue;
    float* line = grid + row * n;
    envelope1d(line, n, line, &(*scratch)[threadId()], Squared());
  }
}

/// Pass along a strided axis. Line (o, x), o < n_outer, x < nx, has its element k (k < n) at
/// grid[o * outer_stride + k * stride + x]. Lines are processed kBlock consecutive x at a time.
/// If mask is given, line (o, x) is transformed only when mask[o * mask_outer_stride + x] is
/// nonzero (the others are left as they are; mask_outer_stride 0 uses one mask for every o).
void stridedPass(float* grid, int nx, int64_t n_outer, int64_t outer_stride, int n, int64_t stride,
                 const uint8_t* mask, int64_t mask_outer_stride,
                 std::vector<LineScratch>* scratch) {
  const int64_t n_blocks = (nx + kBlock - 1) / kBlock;
  const int64_t n_items = n_outer * n_blocks;
#pragma omp parallel for schedule(dynamic, 2) if (n_outer * nx * n >= kMinParallelCells)
  for (int64_t item = 0; item < n_items; ++item) {
    const int64_t o = item / n_blocks;
    const int x0 = static_cast<int>((item % n_blocks) * kBlock);
    const int bw = std::min(kBlock, nx - x0);
    const uint8_t* m = mask ? mask + o * mask_outer_stride + x0 : nullptr;
    if (m) {
      bool any = false;
      for (int b = 0; b < bw; ++b) any = any || m[b] != 0;
      if (!any) continue;
    }
    LineScratch& s = (*scratch)[threadId()];
    float* base = grid + o * outer_stride + x0;
    float* block = s.block.data();
    for (int k = 0; k < n; ++k) {
      const float* src = base + k * stride;
      for (int b = 0; b < bw; ++b) block[b * n + k] = src[b];
    }
    for (int b = 0; b < bw; ++b) {
      if (m && !m[b]) continue;
      float* line = block + b * n;
      envelope1d(line, n, line, &s, Squared());
    }
    for (int k = 0; k < n; ++k) {
      float* dst = base + k * stride;
      for (int b = 0; b < bw; ++b) dst[b] = block[b * n + k];
    }
  }
}

/// v[i] = (sqrt(v[i]) - 1/2) * h for i < n. The SIMD square root is IEEE correctly rounded like
/// the scalar one, so the result does not depend on which elements take which path (Eigen's
/// fast-math packet sqrt is an approximation and would make results depend on alignment).
void sqrtMinusHalfTimes(float* v, int n, float h) {
  int i = 0;
#if defined(__AVX__)
  const __m256 half8 = _mm256_set1_ps(0.5f), h8 = _mm256_set1_ps(h);
  for (; i + 8 <= n; i += 8) {
    const __m256 x = _mm256_sqrt_ps(_mm256_loadu_ps(v + i));
    _mm256_storeu_ps(v + i, _mm256_mul_ps(_mm256_sub_ps(x, half8), h8));
  }
#elif defined(__SSE2__)
  const __m128 half4 = _mm_set1_ps(0.5f), h4 = _mm_set1_ps(h);
  for (; i + 4 <= n; i += 4) {
    const __m128 x = _mm_sqrt_ps(_mm_loadu_ps(v + i));
    _mm_storeu_ps(v + i, _mm_mul_ps(_mm_sub_ps(x, half4), h4));
  }
#endif
  for (; i < n; ++i) v[i] = (std::sqrt(v[i]) - 0.5f) * h;
}

/// What the first pass over the occupancy learns on the way.
struct ColumnPassInfo {
  std::vector<uint8_t> column_has_site;   ///< per (x, y) of the box, x fastest.
  std::vector<uint8_t> row_has_occupied;  ///< per (y, z) of the box, y fastest.
  int64_t n_occupied = 0;
};

/// Column pass sentinel: "no site yet" is a site this far away (voxels), beyond any grid axis
/// for which squared distances are exact in float (see squaredDistanceTransform).
constexpr int kNoSite = 1 << 25;

/// Forward step of the column pass over one row of n voxels at slab z: last[x] becomes the last
/// site at or below z (-kNoSite if none) and d[x] the distance to it. Branch-free (min/max and
/// selects only) so that it vectorises. Returns the number of occupied voxels of the row.
int forwardRow(const uint8_t* __restrict occ, int flip, int z, int n, int* __restrict last,
               float* __restrict d) {
  int occupied = 0;
  for (int x = 0; x < n; ++x) {
    const int o = occ[x] != 0;
    occupied += o;
    const int site = o ^ flip;
    const int l = std::max(last[x], site * z + (site - 1) * kNoSite);
    last[x] = l;
    d[x] = static_cast<float>(z - l);
  }
  return occupied;
}

/// Backward step: next[x] becomes the next site at or above z (kNoSite + z if none); d[x] the
/// squared distance to the nearer of the two, or +infinity if the column has no site.
void backwardRow(const uint8_t* __restrict occ, int flip, int z, int n, int* __restrict next,
                 float* __restrict d) {
  const float far = static_cast<float>(kNoSite / 2);
  for (int x = 0; x < n; ++x) {
    const int site = (occ[x] != 0) ^ flip;
    const int l = std::min(next[x], site * z + (1 - site) * kNoSite);
    next[x] = l;
    const float v = std::min(d[x], static_cast<float>(l - z));
    d[x] = v < far ? v * v : kInf;
  }
}

/// First pass, along z, straight from the occupancy: for the box lo + [0, sub) of an occupancy
/// grid of dims `full`, out (box layout, x fastest) receives the squared 1-D distance (voxels^2)
/// along z to the nearest site of the column (+infinity for a column without one), where a voxel
/// is a site when (occupied != 0) == site_is_occupied. Slab by slab, so every access is a
/// contiguous row; parallel over y.
void binaryColumnPass(const uint8_t* occ, const Eigen::Vector3i& full, const Eigen::Vector3i& lo,
                      const Eigen::Vector3i& sub, bool site_is_occupied, float* out,
                      ColumnPassInfo* info) {
  const int nx = sub.x(), ny = sub.y(), nz = sub.z();
  const int64_t full_slab = int64_t{full.x()} * full.y();
  const int64_t sub_slab = int64_t{nx} * ny;
  const int flip = site_is_occupied ? 0 : 1;
  info->column_has_site.assign(sub_slab, 0);
  info->row_has_occupied.assign(int64_t{ny} * nz, 0);
  int64_t n_occupied = 0;
  std::vector<std::vector<int>> last_site(maxThreads(), std::vector<int>(nx));
  const bool parallel = sub_slab * nz >= kMinParallelCells;
#pragma omp parallel for schedule(dynamic, 2) reduction(+ : n_occupied) if (parallel)
  for (int y = 0; y < ny; ++y) {
    int* last = last_site[threadId()].data();
    std::fill(last, last + nx, -kNoSite);
    for (int z = 0; z < nz; ++z) {
      const uint8_t* o = occ + (z + lo.z()) * full_slab + int64_t{y + lo.y()} * full.x() + lo.x();
      const int row_occupied =
          forwardRow(o, flip, z, nx, last, out + z * sub_slab + int64_t{y} * nx);
      n_occupied += row_occupied;
      info->row_has_occupied[int64_t{z} * ny + y] = row_occupied > 0;
    }
    uint8_t* has = info->column_has_site.data() + int64_t{y} * nx;
    for (int x = 0; x < nx; ++x) has[x] = last[x] >= 0;
    std::fill(last, last + nx, kNoSite);
    for (int z = nz - 1; z >= 0; --z) {
      const uint8_t* o = occ + (z + lo.z()) * full_slab + int64_t{y + lo.y()} * full.x() + lo.x();
      backwardRow(o, flip, z, nx, last, out + z * sub_slab + int64_t{y} * nx);
    }
  }
  info->n_occupied = n_occupied;
}

bool fail(std::string* error, const std::string& what) {
  if (error) *error = what;
  return false;
}

/// Checks dims and the cell count; on success *cells = dims.prod().
bool checkDims(const char* fn, const Eigen::Vector3i& dims, int64_t* cells, std::string* error) {
  if (dims.x() <= 0 || dims.y() <= 0 || dims.z() <= 0) {
    std::ostringstream s;
    s << fn << ": dims (" << dims.x() << ", " << dims.y() << ", " << dims.z()
      << ") must all be greater than 0";
    return fail(error, s.str());
  }
  if (dims.maxCoeff() > kMaxEdtAxis) {
    std::ostringstream s;
    s << fn << ": dims (" << dims.x() << ", " << dims.y() << ", " << dims.z()
      << ") exceed the limit of " << kMaxEdtAxis << " voxels along an axis";
    return fail(error, s.str());
  }
  const int64_t n = int64_t{dims.x()} * int64_t{dims.y()} * int64_t{dims.z()};
  if (n > kMaxEdtCells) {
    std::ostringstream s;
    s << fn << ": dims (" << dims.x() << ", " << dims.y() << ", " << dims.z() << ") give " << n
      << " cells, more than the limit of " << kMaxEdtCells;
    return fail(error, s.str());
  }
  *cells = n;
  return true;
}

}  // namespace

bool squaredDistanceTransform(std::vector<float>* grid, const Eigen::Vector3i& dims,
                              std::string* error) {
  const char* fn = "squaredDistanceTransform";
  if (!grid) return fail(error, std::string(fn) + ": grid is null");
  int64_t cells = 0;
  if (!checkDims(fn, dims, &cells, error)) return false;
  if (static_cast<int64_t>(grid->size()) != cells) {
    std::ostringstream s;
    s << fn << ": grid has " << grid->size() << " values but dims (" << dims.x() << ", " << dims.y()
      << ", " << dims.z() << ") need " << cells;
    return fail(error, s.str());
  }
  for (int64_t i = 0; i < cells; ++i) {
    const float f = (*grid)[i];
    if (!(f >= 0.0f)) {  // Also catches NaN.
      std::ostringstream s;
      s << fn << ": grid[" << i << "] = " << f << ", values must be >= 0 or +infinity";
      return fail(error, s.str());
    }
  }
  try {
    std::vector<float> work(*grid);
    const int nx = dims.x(), ny = dims.y(), nz = dims.z();
    const int64_t slab = int64_t{nx} * ny;
    std::vector<LineScratch> scratch = makeScratch(dims.maxCoeff());
    contiguousPass(work.data(), nx, int64_t{ny} * nz, nullptr, &scratch);
    if (ny > 1) stridedPass(work.data(), nx, nz, slab, ny, nx, nullptr, 0, &scratch);
    if (nz > 1) stridedPass(work.data(), nx, ny, nx, nz, slab, nullptr, 0, &scratch);
    grid->swap(work);
  } catch (const std::bad_alloc&) {
    return fail(error, std::string(fn) + ": out of memory");
  }
  return true;
}

bool buildSignedDistanceField(const std::vector<uint8_t>& occupied, const Eigen::Vector3i& dims,
                              double voxel_m, const Vec3& origin_m, DenseSdf* out,
                              std::string* error) {
  const char* fn = "buildSignedDistanceField";
  if (!out) return fail(error, std::string(fn) + ": out is null");
  if (!std::isfinite(voxel_m) || voxel_m <= 0.0) {
    std::ostringstream s;
    s << fn << ": voxel_m = " << voxel_m << " must be a finite number greater than 0";
    return fail(error, s.str());
  }
  if (!origin_m.allFinite()) {
    return fail(error, std::string(fn) + ": origin_m must have finite components");
  }
  int64_t cells = 0;
  if (!checkDims(fn, dims, &cells, error)) return false;
  if (static_cast<int64_t>(occupied.size()) != cells) {
    std::ostringstream s;
    s << fn << ": occupied has " << occupied.size() << " entries but dims (" << dims.x() << ", "
      << dims.y() << ", " << dims.z() << ") need " << cells;
    return fail(error, s.str());
  }

  const int nx = dims.x(), ny = dims.y(), nz = dims.z();
  const int64_t slab = int64_t{nx} * ny;
  const float h = static_cast<float>(voxel_m);

  // Passes: z straight from the occupancy (a 1-D scan), then y and x lower envelopes; the last
  // (x, contiguous) pass of d_out also writes the signed field. d_in is computed first, on the
  // bounding box of the occupied voxels grown by one voxel: the nearest free voxel of any
  // occupied voxel lies in there (outside that box every voxel is free, and projecting a free
  // voxel onto the box brings it closer). Lines whose output is never needed, or whose input is
  // all +infinity, are skipped.
  try {
    DenseSdf sdf;
    sdf.origin_m = origin_m;
    sdf.voxel_m = voxel_m;
    sdf.dims = dims;
    sdf.distance_m.resize(cells);
    float* field = sdf.distance_m.data();
    std::vector<LineScratch> scratch = makeScratch(dims.maxCoeff());

    // d_out, pass 1 (z): sites are the occupied voxels.
    ColumnPassInfo out_info;
    binaryColumnPass(occupied.data(), dims, Eigen::Vector3i::Zero(), dims, true, field, &out_info);
    const int64_t n_occupied = out_info.n_occupied;
    if (n_occupied == 0 || n_occupied == cells) {
      const double diag = voxel_m * dims.cast<double>().norm();
      std::fill(sdf.distance_m.begin(), sdf.distance_m.end(),
                static_cast<float>(n_occupied == 0 ? diag : -diag));
      *out = std::move(sdf);
      return true;
    }

    // Bounding box of the occupied voxels, grown by one voxel and clipped to the grid.
    Eigen::Vector3i lo(nx, ny, nz), hi(-1, -1, -1);
    for (int y = 0; y < ny; ++y) {
      for (int x = 0; x < nx; ++x) {
        if (out_info.column_has_site[int64_t{y} * nx + x]) {
          lo.x() = std::min(lo.x(), x);
          hi.x() = std::max(hi.x(), x);
        }
      }
    }
    for (int z = 0; z < nz; ++z) {
      for (int y = 0; y < ny; ++y) {
        if (out_info.row_has_occupied[int64_t{z} * ny + y]) {
          lo.y() = std::min(lo.y(), y);
          hi.y() = std::max(hi.y(), y);
          lo.z() = std::min(lo.z(), z);
          hi.z() = std::max(hi.z(), z);
        }
      }
    }
    lo = (lo.array() - 1).max(0).matrix();
    hi = (hi.array() + 1).min(Eigen::Array3i(nx - 1, ny - 1, nz - 1)).matrix();
    const Eigen::Vector3i sub = hi - lo + Eigen::Vector3i::Ones();
    const int64_t sub_slab = int64_t{sub.x()} * sub.y();

    // d_in^2 on the sub-box: sites are the free voxels; needed only on rows holding an occupied
    // voxel (x pass), so only on slabs holding one (y pass).
    std::vector<float> din(static_cast<size_t>(sub_slab) * sub.z());
    ColumnPassInfo in_info;
    binaryColumnPass(occupied.data(), dims, lo, sub, false, din.data(), &in_info);
    std::vector<uint8_t> slab_needed(sub.z(), 0);
    for (int z = 0; z < sub.z(); ++z) {
      for (int y = 0; y < sub.y() && !slab_needed[z]; ++y) {
        slab_needed[z] = in_info.row_has_occupied[int64_t{z} * sub.y() + y];
      }
    }
    if (sub.y() > 1) {
      // Line (z, x) of the y pass: mask entry z (one per slab, broadcast over x).
      std::vector<uint8_t> y_mask(int64_t{sub.z()} * sub.x());
      for (int z = 0; z < sub.z(); ++z) {
        std::fill(y_mask.begin() + int64_t{z} * sub.x(), y_mask.begin() + int64_t{z + 1} * sub.x(),
                  slab_needed[z]);
      }
      stridedPass(din.data(), sub.x(), sub.z(), sub_slab, sub.y(), sub.x(), y_mask.data(), sub.x(),
                  &scratch);
    }
    contiguousPass(din.data(), sub.x(), int64_t{sub.y()} * sub.z(), in_info.row_has_occupied.data(),
                   &scratch);

    // d_out, pass 2 (y): line (z, x) holds a finite value only if some column at x has a site.
    if (ny > 1) {
      std::vector<uint8_t> x_has_site(nx, 0);
      for (int y = 0; y < ny; ++y) {
        for (int x = 0; x < nx; ++x) x_has_site[x] |= out_info.column_has_site[int64_t{y} * nx + x];
      }
      stridedPass(field, nx, nz, slab, ny, nx, x_has_site.data(), 0, &scratch);
    }

    // d_out, pass 3 (x), fused with the signed field:
    // sdf = (sqrt(d_out^2) - 1/2) h outside, -(sqrt(d_in^2) - 1/2) h inside.
#pragma omp parallel for schedule(dynamic, 32) if (cells >= kMinParallelCells)
    for (int64_t row = 0; row < int64_t{ny} * nz; ++row) {
      const int y = static_cast<int>(row % ny), z = static_cast<int>(row / ny);
      float* line = field + row * nx;
      envelope1d(line, nx, line, &scratch[threadId()], Squared());
      sqrtMinusHalfTimes(line, nx, h);
      if (!out_info.row_has_occupied[row]) continue;
      // Occupied voxels always lie inside the sub-box; di[x - lo.x()] is d_in^2 at (x, y, z).
      const uint8_t* occ = occupied.data() + row * nx;
      const float* di = din.data() + (z - lo.z()) * sub_slab + int64_t{y - lo.y()} * sub.x();
      for (int x = lo.x(); x <= hi.x(); ++x) {
        if (occ[x]) line[x] = -(std::sqrt(di[x - lo.x()]) - 0.5f) * h;
      }
    }
    *out = std::move(sdf);
  } catch (const std::bad_alloc&) {
    std::ostringstream s;
    s << fn << ": out of memory for a grid of " << cells << " cells";
    return fail(error, s.str());
  }
  return true;
}

}  // namespace wet_curly_hair

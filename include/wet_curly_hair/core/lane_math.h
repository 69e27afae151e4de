// Arithmetic shared by every path of the solver: one strand at a time (the scalar S = double, a
// plain bool as the mask) and blocks of strands in SIMD lanes (S a GCC vector of W doubles or
// floats, one strand per lane, an integer vector as the mask). The physical laws (springs.h,
// frames.h, head_collider.h, wet_kernels.h) are written once as templates over S on these
// types, so the reference path and every lane layout run the same code.
//
// A rare branch (a half-turn frame rotation, a particle at the centre of a head shape) is not
// vectorised: the kernel computes the common branch on every lane and patches the lanes that
// need the rare one with its scalar form (patchLanes); with S = double that is a plain `if`.
#pragma once

#include <cmath>
#include <cstdint>
#include <cstring>
#include <type_traits>
#include <utility>

#ifdef __AVX__
#include <immintrin.h>
#endif

#include "wet_curly_hair/core/types.h"

/// Inlined always: the kernels are small, and GCC's inlining heuristics differ between lane
/// widths; a kernel inlined in one layout and called in another would fuse multiply-adds
/// differently, and layouts that compute the same operations lane by lane would no longer agree
/// to the last bit.
#define WCH_INLINE inline __attribute__((always_inline))

namespace wet_curly_hair {

// ------------------------------------------------------------------ lane scalars

/// Element type, width and mask type of a lane scalar S (double, float or a GCC vector of them).
template <typename S, typename Enable = void>
struct LaneTraits {
  using Elem = std::decay_t<decltype(std::declval<S>()[0])>;
  static constexpr int kWidth = static_cast<int>(sizeof(S) / sizeof(Elem));
  using Mask = decltype(std::declval<S>() < std::declval<S>());
};
template <typename S>
struct LaneTraits<S, std::enable_if_t<std::is_floating_point<S>::value>> {
  using Elem = S;
  static constexpr int kWidth = 1;
  using Mask = bool;
};

/// The lane layouts of the strand-block stepper: strands per block and arithmetic.
typedef double LaneDouble4 __attribute__((vector_size(32)));
typedef double LaneDouble8 __attribute__((vector_size(64)));
typedef float LaneFloat8 __attribute__((vector_size(32)));
typedef float LaneFloat16 __attribute__((vector_size(64)));

template <typename S>
using LaneMask = typename LaneTraits<S>::Mask;
template <typename S>
constexpr int kLaneWidth = LaneTraits<S>::kWidth;

/// The same value in every lane.
template <typename S>
WCH_INLINE S splat(double x) {
  return S{} + static_cast<typename LaneTraits<S>::Elem>(x);
}

/// Value of lane l (for S = double, l is 0 and the value is x).
WCH_INLINE double laneValue(double x, int) { return x; }
WCH_INLINE double laneValue(float x, int) { return x; }
template <typename S, typename = std::enable_if_t<!std::is_floating_point<S>::value>>
WCH_INLINE double laneValue(const S& x, int l) {
  return x[l];
}
WCH_INLINE void setLaneValue(double* x, int, double value) { *x = value; }
WCH_INLINE void setLaneValue(float* x, int, double value) { *x = static_cast<float>(value); }
template <typename S, typename = std::enable_if_t<!std::is_floating_point<S>::value>>
WCH_INLINE void setLaneValue(S* x, int l, double value) {
  (*x)[l] = static_cast<typename LaneTraits<S>::Elem>(value);
}

/// True where any lane of the mask is set.
WCH_INLINE bool anyLane(bool m) { return m; }
template <typename M, typename = std::enable_if_t<!std::is_same<M, bool>::value>>
WCH_INLINE bool anyLane(const M& m) {
#if defined(__AVX__)
  // One test of the whole register; the lane by lane OR below extracts every lane.
  if constexpr (sizeof(M) == 32) {
    __m256i bits;
    std::memcpy(&bits, &m, 32);
    return !_mm256_testz_si256(bits, bits);
  }
#endif
#if defined(__AVX512F__)
  // The 64-byte masks of float16 and double8 lanes too: the lane by lane OR took 6 % of a step
  // of 10,000 strands (theta 1/240 s), every row's contact and limit tests.
  if constexpr (sizeof(M) == 64) {
    __m512i bits;
    std::memcpy(&bits, &m, 64);
    return _mm512_test_epi64_mask(bits, bits) != 0;
  }
#endif
  // Without AVX-512 a 64-byte mask stays here: with its halves ORed and tested once, the first
  // README 10,000-strand command ran at 0.94x the real-time factor (float16 lanes in an
  // x86-64-v3 build, 6 pairs).
  std::decay_t<decltype(m[0])> r = 0;
  for (int l = 0; l < static_cast<int>(sizeof(M) / sizeof(m[0])); ++l) r |= m[l];
  return r != 0;
}
WCH_INLINE bool maskLane(bool m, int) { return m; }
template <typename M, typename = std::enable_if_t<!std::is_same<M, bool>::value>>
WCH_INLINE bool maskLane(const M& m, int l) {
  return m[l] != 0;
}

/// a where the mask is set, b elsewhere (both are evaluated).
template <typename M, typename S>
WCH_INLINE S select(const M& m, const S& a, const S& b) {
  return m ? a : b;
}

/// Lane by lane std::max / std::min, including their answers for NaN (a unless a < b).
template <typename S>
WCH_INLINE S vmax(const S& a, const S& b) {
  return select(a < b, b, a);
}
template <typename S>
WCH_INLINE S vmin(const S& a, const S& b) {
  return select(b < a, b, a);
}

WCH_INLINE double vsqrt(double x) { return std::sqrt(x); }
WCH_INLINE float vsqrt(float x) { return std::sqrt(x); }
template <typename S, typename = std::enable_if_t<!std::is_floating_point<S>::value>>
WCH_INLINE S vsqrt(const S& x) {
  using Elem = typename LaneTraits<S>::Elem;
  constexpr bool kFloat = std::is_same<Elem, float>::value;
#if defined(__AVX512F__)
  if constexpr (sizeof(S) == 64) {
    if constexpr (kFloat)
      return _mm512_sqrt_ps(x);
    else
      return _mm512_sqrt_pd(x);
  }
#endif
#if defined(__AVX__)
  if constexpr (sizeof(S) == 32) {
    if constexpr (kFloat)
      return _mm256_sqrt_ps(x);
    else
      return _mm256_sqrt_pd(x);
  }
  if constexpr (sizeof(S) == 64) {
    // Two AVX registers (float16 or double8 without AVX-512): one square root per half instead
    // of a scalar std::sqrt per lane (with its errno check).
    typedef Elem Half __attribute__((vector_size(32)));
    Half lo, hi;
    std::memcpy(&lo, &x, 32);
    std::memcpy(&hi, reinterpret_cast<const char*>(&x) + 32, 32);
    lo = vsqrt(lo);
    hi = vsqrt(hi);
    S r;
    std::memcpy(&r, &lo, 32);
    std::memcpy(reinterpret_cast<char*>(&r) + 32, &hi, 32);
    return r;
  }
#endif
  S r;
  for (int l = 0; l < kLaneWidth<S>; ++l) r[l] = std::sqrt(x[l]);
  return r;
}

/// Lanes of a mask type (1 for bool).
template <typename M>
constexpr int maskWidth() {
  if constexpr (std::is_same<M, bool>::value)
    return 1;
  else
    return static_cast<int>(sizeof(M) / sizeof(std::declval<M>()[0]));
}

/// Per-lane counts of set mask lanes, kept as an integer vector (a set lane is -1, so subtracting
/// the mask adds 1 where it is set): a row's contacts counted in one vector operation instead of
/// a scalar loop over the lanes. For S = double (one lane) a plain count.
template <typename S, typename = void>
struct LaneCounts {
  LaneMask<S> count = {};
  WCH_INLINE void add(const LaneMask<S>& m) { count -= m; }
  WCH_INLINE uint64_t lane(int l) const { return static_cast<uint64_t>(count[l]); }
  WCH_INLINE uint64_t total() const {
    uint64_t t = 0;
    for (int l = 0; l < kLaneWidth<S>; ++l) t += lane(l);
    return t;
  }
};
template <typename S>
struct LaneCounts<S, std::enable_if_t<std::is_floating_point<S>::value>> {
  uint64_t count = 0;
  WCH_INLINE void add(bool m) { count += m; }
  WCH_INLINE uint64_t lane(int) const { return count; }
  WCH_INLINE uint64_t total() const { return count; }
};

/// Calls fix(l) for every lane l whose mask is set (the scalar form of a rare branch).
template <typename M, typename F>
WCH_INLINE void patchLanes(const M& rare, F&& fix) {
  if (!anyLane(rare)) return;
  for (int l = 0; l < maskWidth<M>(); ++l)
    if (maskLane(rare, l)) fix(l);
}

// ------------------------------------------------------------------ 3-vectors

/// A 3-vector of lane scalars (for S = double, one plain vector).
template <typename S>
struct V3 {
  S x, y, z;
};
template <typename S>
WCH_INLINE V3<S> operator+(const V3<S>& a, const V3<S>& b) {
  return {a.x + b.x, a.y + b.y, a.z + b.z};
}
template <typename S>
WCH_INLINE V3<S> operator-(const V3<S>& a, const V3<S>& b) {
  return {a.x - b.x, a.y - b.y, a.z - b.z};
}
template <typename S>
WCH_INLINE V3<S> operator-(const V3<S>& a) {
  return {-a.x, -a.y, -a.z};
}
template <typename S>
WCH_INLINE V3<S> operator*(const S& s, const V3<S>& a) {
  return {s * a.x, s * a.y, s * a.z};
}
template <typename S>
WCH_INLINE V3<S> operator/(const V3<S>& a, const S& s) {
  // One division and three products: a lane division costs several products' time, and this
  // normalises every edge of every strand on every substep (within an ulp of three quotients).
  const S inv = splat<S>(1.0) / s;
  return {a.x * inv, a.y * inv, a.z * inv};
}
template <typename S>
WCH_INLINE V3<S>& operator+=(V3<S>& a, const V3<S>& b) {
  return a = a + b;
}
template <typename S>
WCH_INLINE V3<S>& operator-=(V3<S>& a, const V3<S>& b) {
  return a = a - b;
}
template <typename S>
WCH_INLINE S dot(const V3<S>& a, const V3<S>& b) {
  return a.x * b.x + a.y * b.y + a.z * b.z;
}
template <typename S>
WCH_INLINE V3<S> cross(const V3<S>& a, const V3<S>& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
template <typename M, typename S>
WCH_INLINE V3<S> select(const M& m, const V3<S>& a, const V3<S>& b) {
  return {select(m, a.x, b.x), select(m, a.y, b.y), select(m, a.z, b.z)};
}
template <typename S>
WCH_INLINE V3<S> splat3(const Vec3& a) {
  return {splat<S>(a.x()), splat<S>(a.y()), splat<S>(a.z())};
}
template <typename S>
WCH_INLINE V3<S> zero3() {
  return splat3<S>(Vec3::Zero());
}
template <typename S>
WCH_INLINE Vec3 lane(const V3<S>& a, int l) {
  return Vec3(laneValue(a.x, l), laneValue(a.y, l), laneValue(a.z, l));
}
template <typename S>
WCH_INLINE void setLane(V3<S>* a, int l, const Vec3& v) {
  setLaneValue(&a->x, l, v.x());
  setLaneValue(&a->y, l, v.y());
  setLaneValue(&a->z, l, v.z());
}
/// Conversions between the scalar V3 and Eigen's vector (the public API speaks Eigen).
WCH_INLINE V3<double> toV3(const Vec3& a) { return {a.x(), a.y(), a.z()}; }
WCH_INLINE Vec3 toEigen(const V3<double>& a) { return Vec3(a.x, a.y, a.z); }

// ------------------------------------------------------------------ 3x3 matrices

/// Row-major 3x3 of lane scalars.
template <typename S>
struct M33 {
  S m[3][3];
};
template <typename S>
WCH_INLINE V3<S> operator*(const M33<S>& a, const V3<S>& v) {
  return {a.m[0][0] * v.x + a.m[0][1] * v.y + a.m[0][2] * v.z,
          a.m[1][0] * v.x + a.m[1][1] * v.y + a.m[1][2] * v.z,
          a.m[2][0] * v.x + a.m[2][1] * v.y + a.m[2][2] * v.z};
}
/// a^T v.
template <typename S>
WCH_INLINE V3<S> transposeTimes(const M33<S>& a, const V3<S>& v) {
  return {a.m[0][0] * v.x + a.m[1][0] * v.y + a.m[2][0] * v.z,
          a.m[0][1] * v.x + a.m[1][1] * v.y + a.m[2][1] * v.z,
          a.m[0][2] * v.x + a.m[1][2] * v.y + a.m[2][2] * v.z};
}
template <typename S>
WCH_INLINE M33<S> operator*(const M33<S>& a, const M33<S>& b) {
  M33<S> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      r.m[i][j] = a.m[i][0] * b.m[0][j] + a.m[i][1] * b.m[1][j] + a.m[i][2] * b.m[2][j];
  return r;
}
template <typename S>
WCH_INLINE M33<S> operator+(const M33<S>& a, const M33<S>& b) {
  M33<S> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[i][j] + b.m[i][j];
  return r;
}
template <typename S>
WCH_INLINE M33<S> operator-(const M33<S>& a, const M33<S>& b) {
  M33<S> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = a.m[i][j] - b.m[i][j];
  return r;
}
template <typename S>
WCH_INLINE M33<S> splat33(const Mat3& a) {
  M33<S> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = splat<S>(a(i, j));
  return r;
}
template <typename S>
WCH_INLINE Mat3 lane(const M33<S>& a, int l) {
  Mat3 r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r(i, j) = laneValue(a.m[i][j], l);
  return r;
}
template <typename S>
WCH_INLINE void setLane(M33<S>* a, int l, const Mat3& v) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) setLaneValue(&a->m[i][j], l, v(i, j));
}
WCH_INLINE M33<double> toM33(const Mat3& a) { return splat33<double>(a); }
WCH_INLINE Mat3 toEigen(const M33<double>& a) { return lane(a, 0); }
template <typename S>
WCH_INLINE V3<S> column(const M33<S>& a, int j) {
  return {a.m[0][j], a.m[1][j], a.m[2][j]};
}
template <typename M, typename S>
WCH_INLINE M33<S> select(const M& mask, const M33<S>& a, const M33<S>& b) {
  M33<S> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = select(mask, a.m[i][j], b.m[i][j]);
  return r;
}
/// a I + b u u^T + c w w^T (symmetric).
template <typename S>
WCH_INLINE M33<S> isotropicPlusDyads(const S& a, const S& b, const V3<S>& u, const S& c,
                                     const V3<S>& w) {
  const S uu[3] = {u.x, u.y, u.z};
  const S ww[3] = {w.x, w.y, w.z};
  M33<S> r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.m[i][j] = b * (uu[i] * uu[j]) + c * (ww[i] * ww[j]);
  for (int i = 0; i < 3; ++i) r.m[i][i] += a;
  return r;
}

}  // namespace wet_curly_hair

#include "wet_curly_hair/core/cohesion_grid.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>
#include <utility>

#include "display_write.h"
#include "parallel.h"
#include "wet_curly_hair/core/followers.h"
#include "wet_curly_hair/core/wet_kernels.h"

namespace wet_curly_hair {

using detail::parallelFor;
using detail::parallelRegion;
using detail::parallelSum;
using detail::Schedule;

namespace {

/// The part of the preallocated lattice used this step: origin (the hair's bounding box minus a
/// margin, so every quantity below depends on positions relative to the hair only), spacing and
/// dimensions; node (kx, ky, kz) sits at origin + spacing (kx, ky, kz).
struct Lattice {
  Vec3 origin;
  double h = 0.0;  ///< the kernel's radius, m
  double c = 0.0, inv_c = 0.0;
  int64_t cells = 0;  ///< nodes per kernel radius: h = cells c
  int64_t nx = 0, ny = 0, nz = 0;
  double ka = 0.0, kb = 0.0;  ///< node kernel K(q) = q (q^2 + ka q + kb), q = h^2 - r^2 >= 0
  /// The node kernel of sums convolved on the lattice and interpolated to the particle
  /// (convolveNodeBlocks): two trilinear interpolations, twice the correction.
  double ka_both = 0.0, kb_both = 0.0;
  /// The node the wet sums take their positions from, relative to the origin: the lattice's
  /// middle node (P_n = sum_j t_jn V_j sigma_j (p_j - x_ref), WetNodes).
  Vec3 reference = Vec3::Zero();
  int64_t index(int64_t kx, int64_t ky, int64_t kz) const { return (kz * ny + ky) * nx + kx; }
};

/// A particle's place on the lattice: its position relative to the origin, the lowest node of
/// its cell (integers) and its trilinear fractions in the cell, [0, 1).
struct CellPosition {
  Vec3 r;
  double k[3], t[3];
};

/// The lattice coordinate of position p along one axis, in nodes.
inline double nodeCoordinate(const Lattice& L, const Vec3& p, int axis) {
  return (p[axis] - L.origin[axis]) * L.inv_c;
}

/// The lowest node of a cell along one axis, and the fraction there, from a coordinate r
/// relative to the lattice origin. The one place the lattice's cells are formed: cellPosition for
/// every pass over all particles, and the gathered particles' double own-strand shares and node
/// volumes from their stored coordinates (CohesionNodeGrid::rx.., with the gathers) or from
/// cellPosition's r itself (with the node sums): the stored ones are cellPosition's r to the
/// bit, so every pass agrees with the splat on every cell without storing the cells.
struct CellAxis {
  double node, fraction;
};
WCH_INLINE CellAxis cellAxis(const Lattice& L, double r) {
  const double f = r * L.inv_c;
  const double node = std::floor(f);
  return CellAxis{node, f - node};
}

/// Computed from the position by every pass over all particles (a few operations, where storing
/// them and reading them back in three passes moved 9 doubles per particle through memory).
/// The splat tells its threads' layers apart by nodeCoordinate's z alone, the same r * inv_c:
/// both agree on every particle's layer.
inline CellPosition cellPosition(const Lattice& L, const Vec3& p) {
  CellPosition c;
  c.r = p - L.origin;
  for (int a = 0; a < 3; ++a) {
    const CellAxis axis = cellAxis(L, c.r[a]);
    c.k[a] = axis.node;
    c.t[a] = axis.fraction;
  }
  return c;
}

/// A particle's cell and trilinear fractions in float, for the float own-strand shares, into
/// entry k of the six columns kx, ky, kz, tx, ty, tz (CohesionNodeGrid::kx_f.., or a strand's
/// scratch: strandOwnPairArrays).
inline void storeFloatCell(const CellPosition& cell, float* const column[6], int k) {
  for (int a = 0; a < 3; ++a) {
    column[a][k] = static_cast<float>(cell.k[a]);
    column[3 + a][k] = static_cast<float>(cell.t[a]);
  }
}

/// The vectors of double: one register of the build's widest, 8 lanes with AVX-512 and 4
/// without. An 8-double vector on AVX2 went through the stack at every use (GCC spilled the
/// accumulators): the node sums' pass cost 2.6x the gathers' at 5,000 strands, where with
/// AVX-512 it costs 0.64x, and the double gathers 2.2x their AVX-512 time.
#if defined(__AVX512F__)
constexpr int kDoubleLanes = 8;
#else
constexpr int kDoubleLanes = 4;
#endif

/// A register of Real: 8 floats (one AVX2 register) for the float gathers, or kDoubleLanes
/// doubles for the double gathers, the node convolutions and the node sums' interpolation.
template <typename Real>
struct Lanes;
template <>
struct Lanes<double> {
  typedef double type __attribute__((vector_size(8 * kDoubleLanes)));
};
template <>
struct Lanes<float> {
  typedef float type __attribute__((vector_size(32)));
};
template <typename Real>
constexpr int kLanesOf = sizeof(typename Lanes<Real>::type) / sizeof(Real);

template <typename V, typename Real>
inline V loadLanes(const Real* p) {
  V v;
  std::memcpy(&v, p, sizeof v);
  return v;
}

/// N lanes of float, and two of them joined into 2N.
template <int N>
struct FloatLanes {
  typedef float type __attribute__((vector_size(4 * N)));
};
template <int N, size_t... I>
typename FloatLanes<2 * N>::type concatLanes(typename FloatLanes<N>::type a,
                                             typename FloatLanes<N>::type b,
                                             std::index_sequence<I...>) {
  return __builtin_shufflevector(a, b, static_cast<int>(I)...);
}
template <int N>
typename FloatLanes<2 * N>::type concatLanes(typename FloatLanes<N>::type a,
                                             typename FloatLanes<N>::type b) {
  return concatLanes<N>(a, b, std::make_index_sequence<2 * N>());
}

/// N lanes of double; the sum of N lanes as the sum of the two halves, recursively.
template <int N>
struct DoubleLanes {
  typedef double type __attribute__((vector_size(8 * N)));
};
template <int N, size_t... I>
typename DoubleLanes<N / 2>::type lowHalf(typename DoubleLanes<N>::type v,
                                          std::index_sequence<I...>) {
  return __builtin_shufflevector(v, v, static_cast<int>(I)...);
}
template <int N, size_t... I>
typename DoubleLanes<N / 2>::type highHalf(typename DoubleLanes<N>::type v,
                                           std::index_sequence<I...>) {
  return __builtin_shufflevector(v, v, static_cast<int>(I + N / 2)...);
}
template <int N>
double pairwiseSum(typename DoubleLanes<N>::type v) {
  if constexpr (N == 1) {
    return v[0];
  } else {
    return pairwiseSum<N / 2>(lowHalf<N>(v, std::make_index_sequence<N / 2>()) +
                              highHalf<N>(v, std::make_index_sequence<N / 2>()));
  }
}

/// Sum of a register's lanes, in double, pairwise (a sequential sum cost as much as several
/// rows).
template <typename V>
inline double laneSum(const V& v) {
  constexpr int kN = sizeof(V) / sizeof(v[0]);
  return pairwiseSum<kN>(__builtin_convertvector(v, typename DoubleLanes<kN>::type));
}

/// max(q, 0) lane by lane, as q > 0 ? q : 0 (0 for NaN and for -0 alike): one instruction on
/// a register of 8 floats, where the compare-and-mask form took two (the gathers and the
/// own-strand shares take it at every row and corner).
template <typename V>
WCH_INLINE V positivePart(V q) {
#if defined(__AVX__)
  if constexpr (std::is_same<V, typename FloatLanes<8>::type>::value)
    return _mm256_max_ps(q, _mm256_setzero_ps());
#endif
  const V zero = {};
  return q > zero ? q : zero;
}

/// The node kernel, unnormalised: K(q) = q (q^2 + ka q + kb) with q = h^2 - r^2 >= 0, the poly6
/// kernel of eq. (10) with the lattice's correction (computeDisplayCohesionGrid). Scalars or
/// vector lanes. In Horner's form, an add, a multiply-add and a multiply, where q (q q + ka q +
/// kb) took two multiplies, a multiply-add and an add: every gather evaluates it at each of its
/// ~36 rows, and on a CPU whose 256-bit operations take two 128-bit units (first-generation
/// EPYC) the rows are bound by their count of vector operations (docs/physics.md §7.3).
template <typename T, typename S>
inline T nodeKernel(T q, S ka, S kb) {
  return ((q + ka) * q + kb) * q;
}

/// The rows (fixed ky, kz) that may hold nodes within h = kCells c of the point r (relative to
/// the origin) are 2 kCells nodes wide: kx0 .. kx0 + 2 kCells - 1 holds every node of the row
/// within h (the others get q = 0). Fixed-width rows need no per-row bounds, and the squared
/// offsets dx^2 of a row's nodes are the same for every row; a row is read as whole vectors of 8
/// lanes, the lanes past its width given dx^2 = 4 h^2 (q = 0, so the node they read, which the
/// lattice's padding keeps inside the arrays, counts nothing). The lattice margin keeps every
/// row inside the lattice. Offsets are computed in double and rounded to Real once.
template <int kCells, typename Real>
struct RowWindow {
  typedef typename Lanes<Real>::type V;
  static constexpr int kLanes = kLanesOf<Real>;
  static constexpr int kWidth = 2 * kCells;
  static constexpr int kChunks = (kWidth + kLanes - 1) / kLanes;
  /// One register of floats holds a row (AVX2 builds at 3 and 4 nodes per radius): the offsets
  /// are formed in registers too (setOffsetsInRegisters).
  static constexpr bool kOneFloatRegister = std::is_same<Real, float>::value && kChunks == 1;
  int64_t kx0, ky0, kz0;
  V dx2[kChunks];
  /// Per row and per layer (the first kWidth; one register's worth of room).
  Real dy2[kChunks * kLanes], dz2[kChunks * kLanes];
  RowWindow(const Lattice& L, const Vec3& r, double h2) {
    kx0 = static_cast<int64_t>(std::floor(r.x() * L.inv_c)) - kCells + 1;
    ky0 = static_cast<int64_t>(std::floor(r.y() * L.inv_c)) - kCells + 1;
    kz0 = static_cast<int64_t>(std::floor(r.z() * L.inv_c)) - kCells + 1;
    if constexpr (kOneFloatRegister) {
      setOffsetsInRegisters(L, r, h2);
      return;
    }
    for (int j = 0; j < kChunks * kLanes; ++j) {
      const double d = double(kx0 + j) * L.c - r.x();
      dx2[j / kLanes][j % kLanes] = static_cast<Real>(j < kWidth ? d * d : 4.0 * h2);
    }
    for (int j = 0; j < kWidth; ++j) {
      const double ey = double(ky0 + j) * L.c - r.y(), ez = double(kz0 + j) * L.c - r.z();
      dy2[j] = static_cast<Real>(ey * ey);
      dz2[j] = static_cast<Real>(ez * ez);
    }
  }
  /// The constructor's squared offsets, the same values, as two registers of 4 doubles per axis
  /// rounded to one of 8 floats: the lane by lane form cost about 130 scalar instructions per
  /// gather, a sixth of the rows' (the x lanes past the row's width as there).
  void setOffsetsInRegisters(const Lattice& L, const Vec3& r, double h2) {
    typedef double Quad __attribute__((vector_size(32)));
    typedef float HalfV __attribute__((vector_size(16)));
    const Quad low = {0.0, 1.0, 2.0, 3.0}, high = {4.0, 5.0, 6.0, 7.0};
    auto squares = [&](int64_t k0, double coordinate) {
      const Quad e0 = (double(k0) + low) * L.c - coordinate;
      const Quad e1 = (double(k0) + high) * L.c - coordinate;
      return concatLanes<4>(__builtin_convertvector(e0 * e0, HalfV),
                            __builtin_convertvector(e1 * e1, HalfV));
    };
    const V ey2 = squares(ky0, r.y()), ez2 = squares(kz0, r.z());
    const V lane = {0, 1, 2, 3, 4, 5, 6, 7};
    const auto in_row = lane < V{} + Real(kWidth);
    dx2[0] = in_row ? squares(kx0, r.x()) : V{} + static_cast<Real>(4.0 * h2);
    std::memcpy(dy2, &ey2, sizeof ey2);
    std::memcpy(dz2, &ez2, sizeof ez2);
  }
  /// Calls row(first node, a, b) for every row (ky0 + b, kz0 + a) with a node within h, layer by
  /// layer (in Real: a row at the boundary that round-off lets in has q <= 0 to round-off at
  /// every node). The float rows of a small window (AVX2 builds at 3 and 4 nodes per radius) run
  /// all unrolled instead, as the packed gathers do (PackedRowWindow::forEachGroup): measured at
  /// 3 nodes per radius, 1.7 % of the 1,000-strand target scene's step; the double rows gained
  /// nothing.
  template <typename Row>
  void forEachRow(const Lattice& L, double h2d, Row row) const {
    if constexpr (std::is_same<Real, float>::value && kWidth <= 8) {
#pragma GCC unroll 8
      for (int a = 0; a < kWidth; ++a) {
        const int64_t layer = L.index(kx0, ky0, kz0 + a);
#pragma GCC unroll 8
        for (int b = 0; b < kWidth; ++b) row(layer + b * L.nx, a, b);
      }
      return;
    }
    const Real h2 = static_cast<Real>(h2d);
    for (int a = 0; a < kWidth; ++a) {
      if (dz2[a] >= h2) continue;
      const int64_t layer = L.index(kx0, ky0, kz0 + a);
      for (int b = 0; b < kWidth; ++b) {
        if (dy2[b] + dz2[a] >= h2) continue;
        row(layer + b * L.nx, a, b);
      }
    }
  }
};

/// The smallest power of two that holds a row of the window (2 kCells nodes).
constexpr int paddedRowWidth(int width) {
  int p = 1;
  while (p < width) p *= 2;
  return p;
}

/// The float gathers where two or more rows fit a register of floats (rows of 4 nodes at 2 nodes
/// per radius; with AVX-512 rows of 6 nodes, padded to 8, at 3, and of 8 at 4): kRows rows of one
/// layer (consecutive ky) share a vector, so a gather runs 2-4x fewer vector iterations than with
/// one row per vector. A row of 2 kCells nodes takes kPadded lanes; the lanes past its width are
/// given dx^2 = 4 h^2 (q = 0), as in RowWindow. Same window, same per-node kernel values as
/// RowWindow; only the order of the sums differs.
template <int kCells>
struct PackedRowWindow {
  static constexpr int kWidth = 2 * kCells;
  static constexpr int kPadded = paddedRowWidth(kWidth);
  static constexpr int kVectorLanes = kCohesionFloatLanes;
  static constexpr int kRows = kVectorLanes / kPadded;  ///< rows per vector
  static constexpr int kGroups = kWidth / kRows;        ///< vectors per layer
  static_assert(kRows >= 2 && kRows * kPadded == kVectorLanes && kGroups * kRows == kWidth,
                "rows must tile the register");
  typedef typename FloatLanes<kVectorLanes>::type V;
  typedef typename FloatLanes<kPadded>::type Row;
  int64_t kx0, ky0, kz0;
  V dx2;           ///< per lane: the node's squared x offset (lane % kPadded)
  V dy2[kGroups];  ///< per lane: the row's squared y offset (row g kRows + lane / kPadded)
  float dz2[kWidth];
  PackedRowWindow(const Lattice& L, const Vec3& r, double h2) {
    kx0 = static_cast<int64_t>(std::floor(r.x() * L.inv_c)) - kCells + 1;
    ky0 = static_cast<int64_t>(std::floor(r.y() * L.inv_c)) - kCells + 1;
    kz0 = static_cast<int64_t>(std::floor(r.z() * L.inv_c)) - kCells + 1;
    // One row's squared x offsets, repeated in every row of the register.
    Row row_dx2;
    for (int j = 0; j < kPadded; ++j) {
      const double d = double(kx0 + j) * L.c - r.x();
      row_dx2[j] = static_cast<float>(j < kWidth ? d * d : 4.0 * h2);
    }
    dx2 = repeatRow(row_dx2);
    float row_dy2[kWidth];
    for (int j = 0; j < kWidth; ++j) {
      const double ey = double(ky0 + j) * L.c - r.y(), ez = double(kz0 + j) * L.c - r.z();
      row_dy2[j] = static_cast<float>(ey * ey);
      dz2[j] = static_cast<float>(ez * ez);
    }
    for (int g = 0; g < kGroups; ++g) dy2[g] = rowsOf(row_dy2 + g * kRows);
  }
  /// A row's lanes repeated kRows times.
  static V repeatRow(Row r) {
    if constexpr (kRows == 2) {
      return concatLanes<kPadded>(r, r);
    } else {
      static_assert(kRows == 4, "2 or 4 rows per register");
      const auto two = concatLanes<kPadded>(r, r);
      return concatLanes<2 * kPadded>(two, two);
    }
  }
  /// kRows values, each over its row's kPadded lanes.
  static V rowsOf(const float* v) {
    Row r[kRows];
    for (int k = 0; k < kRows; ++k) r[k] = Row{} + v[k];
    if constexpr (kRows == 2) {
      return concatLanes<kPadded>(r[0], r[1]);
    } else {
      return concatLanes<2 * kPadded>(concatLanes<kPadded>(r[0], r[1]),
                                      concatLanes<kPadded>(r[2], r[3]));
    }
  }
  /// The kRows rows of a group, from its first node, as one vector (row loads joined in
  /// registers: a copy through memory stalled on store forwarding, 2x the whole pass). A padded
  /// row reads nodes past the window's, inside the lattice or its padding.
  static V load(const float* a, int64_t first, int64_t nx) {
    Row r[kRows];
    for (int k = 0; k < kRows; ++k) r[k] = loadLanes<Row>(a + first + k * nx);
    if constexpr (kRows == 2) {
      return concatLanes<kPadded>(r[0], r[1]);
    } else {
      return concatLanes<2 * kPadded>(concatLanes<kPadded>(r[0], r[1]),
                                      concatLanes<kPadded>(r[2], r[3]));
    }
  }
  /// Calls group(first node, g, dz^2) for every group of the window, unrolled: a group beyond
  /// h has q = 0 at every node. Skipping those (a quarter at 3 nodes per radius) mispredicted
  /// enough to cost more than they do: measured with skipping, the density gather 10 % and the
  /// wet gather 11 % slower at 3 nodes per radius, 15 % and 7 % at 4 (1,000 strands, AVX-512).
  template <typename Group>
  void forEachGroup(const Lattice& L, Group group) const {
#pragma GCC unroll 8
    for (int a = 0; a < kWidth; ++a) {
      const int64_t layer = L.index(kx0, ky0, kz0 + a);
#pragma GCC unroll 8
      for (int g = 0; g < kGroups; ++g) group(layer + g * kRows * L.nx, g, dz2[a]);
    }
  }
  /// The lanes' sum in double, pairwise in vectors (a sequential sum of the 16 lanes cost a third
  /// of a gather).
  static double sum(const V& v) {
    return pairwiseSum<kVectorLanes>(
        __builtin_convertvector(v, typename DoubleLanes<kVectorLanes>::type));
  }
};

/// Whether the packed float gathers apply at kCells nodes per radius.
template <int kCells>
constexpr bool kPackedRows = kCohesionFloatLanes / paddedRowWidth(2 * kCells) >= 2 &&
                             (2 * kCells) % (kCohesionFloatLanes / paddedRowWidth(2 * kCells)) == 0;

/// Node arrays of pass 2 (eq. 10 over all strands). The positions are taken from one node for
/// the whole lattice, x_ref (Lattice::reference), not from each node: eq. (10)'s pull at p_i,
/// sum_n W_in sum_j t_jn V_j sigma_j (p_j - p_i), is then sum_n W_in P_n - (p_i - x_ref) sum_n
/// W_in S_n, two sums where Q_n = V sigma (p - x_n) needed the node's offset from p_i at every
/// node (wetSums).
template <typename Real>
struct WetNodes {
  const Real* volume;      ///< V
  const Real* wet_volume;  ///< S = V sigma
  const Real* qx;          ///< P = V sigma (p - x_ref)
  const Real* qy;
  const Real* qz;
};

struct WetSums {
  double weight = 0.0;       ///< sum_n W_in V_n
  Vec3 pull = Vec3::Zero();  ///< sum_n W_in sum_j t_jn V_j sigma_j (p_j - p_i)
};

/// A gather's sums at the particle r (relative to the origin), sum W V, sum W S and sum W P,
/// as eq. (10)'s weight and pull (WetNodes).
WCH_INLINE WetSums wetSums(const Lattice& L, const Vec3& r, double weight, double wet,
                           const Vec3& pull_from_reference) {
  WetSums sums;
  sums.weight = weight;
  // Coordinate by coordinate: as one Eigen expression GCC called it out of line, through the
  // PLT, once per particle (the node sums' last pass took 1.2x as long).
  for (int a = 0; a < 3; ++a) sums.pull[a] = pull_from_reference[a] - (r[a] - L.reference[a]) * wet;
  return sums;
}

/// The row gathers. Per row: q from h^2 - dx^2 less the layer's dz^2 and the row's dy^2, the
/// kernel, and five multiply-adds: the sums of w V, w S and w P (WetNodes). With Q_n = V sigma
/// (p - x_n) a row also needed w S times the row's y offset and a per-layer sum of w S for z:
/// the display pass at 10,000 strands, K = 10 costs 0.85-0.91x without them (docs/physics.md
/// §7.3).
template <int kCells, typename Real>
WetSums gatherWet(const Lattice& L, const WetNodes<Real>& g, const Vec3& r, double h2d) {
  typedef RowWindow<kCells, Real> Window;
  typedef typename Window::V V;
  constexpr int kChunks = Window::kChunks;
  const Window win(L, r, h2d);
  const Real ka = static_cast<Real>(L.ka), kb = static_cast<Real>(L.kb);
  const Real h2 = static_cast<Real>(h2d);
  V reach[kChunks];  // h^2 - dx^2 of each lane's node
  for (int c = 0; c < kChunks; ++c) reach[c] = h2 - win.dx2[c];
  V aw[kChunks] = {}, as[kChunks] = {}, ax[kChunks] = {}, ay[kChunks] = {}, az[kChunks] = {};
  win.forEachRow(L, h2d, [&](int64_t first, int a, int b) {
    for (int c = 0; c < kChunks; ++c) {
      const int64_t k = first + c * Window::kLanes;
      const V q = positivePart((reach[c] - win.dz2[a]) - win.dy2[b]);
      const V w = nodeKernel(q, ka, kb);
      aw[c] += w * loadLanes<V>(g.volume + k);
      as[c] += w * loadLanes<V>(g.wet_volume + k);
      ax[c] += w * loadLanes<V>(g.qx + k);
      ay[c] += w * loadLanes<V>(g.qy + k);
      az[c] += w * loadLanes<V>(g.qz + k);
    }
  });
  double weight = 0.0, wet = 0.0;
  Vec3 pull = Vec3::Zero();
  for (int c = 0; c < kChunks; ++c) {
    weight += laneSum(aw[c]);
    wet += laneSum(as[c]);
    pull += Vec3(laneSum(ax[c]), laneSum(ay[c]), laneSum(az[c]));
  }
  return wetSums(L, r, weight, wet, pull);
}

/// gatherWet in float with packed rows.
template <int kCells>
WetSums gatherWetPacked(const Lattice& L, const WetNodes<float>& g, const Vec3& r, double h2d) {
  typedef PackedRowWindow<kCells> Window;
  typedef typename Window::V V;
  const Window win(L, r, h2d);
  const float ka = static_cast<float>(L.ka), kb = static_cast<float>(L.kb);
  const float h2 = static_cast<float>(h2d);
  const int64_t nx = L.nx;
  const V zero = {};
  V aw = zero, as = zero, ax = zero, ay = zero, az = zero;
  win.forEachGroup(L, [&](int64_t first, int grp, float dz2) {
    V q = h2 - (win.dx2 + (win.dy2[grp] + dz2));
    q = q > zero ? q : zero;
    const V w = nodeKernel(q, ka, kb);
    aw += w * Window::load(g.volume, first, nx);
    as += w * Window::load(g.wet_volume, first, nx);
    ax += w * Window::load(g.qx, first, nx);
    ay += w * Window::load(g.qy, first, nx);
    az += w * Window::load(g.qz, first, nx);
  });
  return wetSums(L, r, Window::sum(aw), Window::sum(as),
                 Vec3(Window::sum(ax), Window::sum(ay), Window::sum(az)));
}

/// The float gathers: packed rows where they tile a register, one row per vector elsewhere.
template <int kCells>
WetSums gatherWetSingle(const Lattice& L, const WetNodes<float>& g, const Vec3& r, double h2) {
  if constexpr (kPackedRows<kCells>)
    return gatherWetPacked<kCells>(L, g, r, h2);
  else
    return gatherWet<kCells>(L, g, r, h2);
}

/// The node volumes of CohesionConfig::grid_node_volumes: particle j's share of node n's volume is
/// t_jn m_j / rho_n, the density taken at the node, where the particle volumes give it t_jn V_j.
/// The own-strand shares weight each corner of a particle's cell by cornerFactors: m_j / rho_n at
/// the 8 nodes (x fastest, then y, then z), or 1 each with the particle volumes (the volume then
/// multiplies the corners' sum, as the splat did).
struct NodeVolumes {
  const double* inverse_density = nullptr;  ///< 1 / rho_n, 0 where no mass was splatted
  const double* mass = nullptr;             ///< HairModel::mass_kg
  template <bool kNodeVolumes, typename Real>
  WCH_INLINE void cornerFactors(const Lattice& L, const CohesionNodeGrid& g, int j,
                                Real* factor) const {
    if constexpr (!kNodeVolumes) {
      for (int k = 0; k < 8; ++k) factor[k] = Real(1);
    } else {
      const int64_t n = L.index(static_cast<int64_t>(cellAxis(L, g.rx[j]).node),
                                static_cast<int64_t>(cellAxis(L, g.ry[j]).node),
                                static_cast<int64_t>(cellAxis(L, g.rz[j]).node));
      const int64_t up = L.nx * L.ny;
      const int64_t offset[8] = {0, 1, L.nx, L.nx + 1, up, up + 1, up + L.nx, up + L.nx + 1};
      for (int k = 0; k < 8; ++k)
        factor[k] = static_cast<Real>(mass[j] * inverse_density[n + offset[k]]);
    }
  }
};

/// The own strand's share of the lattice sums for particle i: over the strand's particles j
/// (i included), W~_ij = sum over the 8 nodes x_n of j's cell of t_jn W(|p_i - x_n|), the
/// functional the lattice applies to one particle, summed as V_j W~_ij and V_j sigma_j W~_ij
/// (p_j - p_i). Particles beyond the kernel's reach get q = 0 at every corner, so no distance
/// test is needed and the strand runs in SIMD lanes.
template <bool kNodeVolumes>
inline WetSums ownStrandShare(const Lattice& L, const CohesionNodeGrid& g, const NodeVolumes& nv,
                              int begin, int end, int i, double h2) {
  const double* __restrict rx = g.rx.data();
  const double* __restrict ry = g.ry.data();
  const double* __restrict rz = g.rz.data();
  const double* __restrict vol = g.volume.data();
  const double* __restrict wet = g.wet_share.data();
  const double xi = rx[i], yi = ry[i], zi = rz[i], c = L.c, ka = L.ka, kb = L.kb;
  double w_sum = 0.0, px = 0.0, py = 0.0, pz = 0.0;
#pragma omp simd reduction(+ : w_sum, px, py, pz)
  for (int j = begin; j < end; ++j) {
    const CellAxis cx = cellAxis(L, rx[j]), cy = cellAxis(L, ry[j]), cz = cellAxis(L, rz[j]);
    const double dx0 = cx.node * c - xi, dx1 = (cx.node + 1.0) * c - xi;
    const double dy0 = cy.node * c - yi, dy1 = (cy.node + 1.0) * c - yi;
    const double dz0 = cz.node * c - zi, dz1 = (cz.node + 1.0) * c - zi;
    const double x2[2] = {dx0 * dx0, dx1 * dx1}, y2[2] = {dy0 * dy0, dy1 * dy1},
                 z2[2] = {dz0 * dz0, dz1 * dz1};
    const double wx[2] = {1.0 - cx.fraction, cx.fraction}, wy[2] = {1.0 - cy.fraction, cy.fraction},
                 wz[2] = {1.0 - cz.fraction, cz.fraction};
    double corner[8];
    nv.cornerFactors<kNodeVolumes>(L, g, j, corner);
    double wt = 0.0;
    for (int az = 0; az < 2; ++az)
      for (int ay = 0; ay < 2; ++ay)
        for (int ax = 0; ax < 2; ++ax) {
          const double q = std::max(0.0, h2 - (x2[ax] + y2[ay] + z2[az]));
          wt += (wx[ax] * wy[ay] * wz[az] * corner[(az * 2 + ay) * 2 + ax]) * nodeKernel(q, ka, kb);
        }
    const double ws = wet[j] * wt;
    w_sum += (kNodeVolumes ? 1.0 : vol[j]) * wt;
    px += ws * (rx[j] - xi);
    py += ws * (ry[j] - yi);
    pz += ws * (rz[j] - zi);
  }
  WetSums share;
  share.weight = w_sum;
  share.pull = Vec3(px, py, pz);
  return share;
}

/// Lanes of the float own-strand pass: one register of floats.
typedef float OwnLanes __attribute__((vector_size(4 * kCohesionFloatLanes)));

/// A strand's single-precision own-pair inputs and outputs, indexed from its first particle
/// (ownSharesInLanes): the cells and fractions (CohesionNodeGrid::kx_f..), volumes and wet shares
/// in, the shares out, each with room for kCohesionFloatLanes particles past the strand's end.
struct OwnPairArrays {
  const float *kx, *ky, *kz, *tx, *ty, *tz, *volume, *wet_share;
  float *weight, *px, *py, *pz;
};

/// The view of the grid's own arrays (CohesionNodeGrid::kx_f.., own_*_f) at particle begin.
OwnPairArrays gridOwnPairArrays(CohesionNodeGrid* g, int begin) {
  return {g->kx_f.data() + begin,     g->ky_f.data() + begin,        g->kz_f.data() + begin,
          g->tx_f.data() + begin,     g->ty_f.data() + begin,        g->tz_f.data() + begin,
          g->volume_f.data() + begin, g->wet_share_f.data() + begin, g->own_weight_f.data() + begin,
          g->own_px_f.data() + begin, g->own_py_f.data() + begin,    g->own_pz_f.data() + begin};
}

/// A strand's own-strand shares in single precision for every particle i of the strand (count
/// particles, a's indices), stored in a.weight, a.px..: sum_j w_ij of V_j (of 1 with
/// particle_volumes false: the weight carries the volume) and of V_j sigma_j (p_j - p_i), with
/// w_ij = pair_weight(j, e) and e the offset from p_i to the lowest node of j's cell. The
/// particles i sit in lanes and the strand's particles j come one at a time, so every lane sums
/// its own j in order and no horizontal sum is needed (with j in lanes, the 16-lane reductions of
/// 4 sums cost as much as the 2 vector iterations of a 32-particle strand). Lengths are in
/// lattice units (divided by c), so q and the kernel are O(1) and the sums scale back by c^6 and
/// c^7. The offsets are formed as (k_j - k_i) - t_i: the cell difference is an exact integer in
/// float, so each offset carries one rounding of its own size (relative 6e-8), not one of the
/// lattice coordinates. Lanes past the strand's end read past it (the next strand, or padding)
/// and are not stored.
template <typename PairWeight>
WCH_INLINE void ownSharesInLanes(const OwnPairArrays& a, int count, bool particle_volumes,
                                 PairWeight pair_weight) {
  typedef OwnLanes V;
  constexpr int kW = kCohesionFloatLanes;
  const float* __restrict kx = a.kx;
  const float* __restrict ky = a.ky;
  const float* __restrict kz = a.kz;
  const float* __restrict tx = a.tx;
  const float* __restrict ty = a.ty;
  const float* __restrict tz = a.tz;
  const float* __restrict vol = a.volume;
  const float* __restrict wet = a.wet_share;
  const V zero = {};
  for (int i0 = 0; i0 < count; i0 += kW) {
    const V kxi = loadLanes<V>(kx + i0), kyi = loadLanes<V>(ky + i0), kzi = loadLanes<V>(kz + i0);
    const V txi = loadLanes<V>(tx + i0), tyi = loadLanes<V>(ty + i0), tzi = loadLanes<V>(tz + i0);
    V w_sum = zero, px = zero, py = zero, pz = zero;
    for (int j = 0; j < count; ++j) {
      const V ex = (kx[j] - kxi) - txi, ey = (ky[j] - kyi) - tyi, ez = (kz[j] - kzi) - tzi;
      const V wt = pair_weight(j, ex, ey, ez);
      const V ws = wet[j] * wt;
      w_sum += (particle_volumes ? vol[j] : 1.0f) * wt;
      px += ws * (ex + tx[j]);  // (p_j - p_i) / c = (k_j - k_i) + t_j - t_i
      py += ws * (ey + ty[j]);
      pz += ws * (ez + tz[j]);
    }
    const int lanes = std::min(kW, count - i0);
    if (lanes == kW) {  // whole registers (lane by lane the compiler went through the stack)
      std::memcpy(a.weight + i0, &w_sum, sizeof(V));
      std::memcpy(a.px + i0, &px, sizeof(V));
      std::memcpy(a.py + i0, &py, sizeof(V));
      std::memcpy(a.pz + i0, &pz, sizeof(V));
      continue;
    }
    for (int l = 0; l < lanes; ++l) {
      a.weight[i0 + l] = w_sum[l];
      a.px[i0 + l] = px[l];
      a.py[i0 + l] = py[l];
      a.pz[i0 + l] = pz[l];
    }
  }
}

/// ownStrandShare in single precision (ownSharesInLanes): w_ij the functional the lattice applies
/// to one particle, the kernel at the 8 corners of j's cell.
template <bool kNodeVolumes>
void ownStrandSharesSingle(const Lattice& L, CohesionNodeGrid* g, const NodeVolumes& nv, int begin,
                           int end) {
  typedef OwnLanes V;
  const OwnPairArrays a = gridOwnPairArrays(g, begin);
  const float* __restrict tx = a.tx;
  const float* __restrict ty = a.ty;
  const float* __restrict tz = a.tz;
  const double c2 = L.c * L.c;
  const float h2 = static_cast<float>(double(L.cells * L.cells));
  const float ka = static_cast<float>(L.ka / c2), kb = static_cast<float>(L.kb / (c2 * c2));
  ownSharesInLanes(a, end - begin, !kNodeVolumes,
                   [&](int j, const V& ex, const V& ey, const V& ez) {
                     // h^2 less the squared distance to each corner, as (h^2 - x^2) - (y^2 + z^2):
                     // the two x terms and four y-z sums are shared by the 8 corners.
                     const V reach_x[2] = {h2 - ex * ex, h2 - (ex + 1.0f) * (ex + 1.0f)};
                     const V y2[2] = {ey * ey, (ey + 1.0f) * (ey + 1.0f)},
                             z2[2] = {ez * ez, (ez + 1.0f) * (ez + 1.0f)};
                     const float wx[2] = {1.0f - tx[j], tx[j]}, wy[2] = {1.0f - ty[j], ty[j]},
                                 wz[2] = {1.0f - tz[j], tz[j]};
                     float corner[8];
                     nv.cornerFactors<kNodeVolumes>(L, *g, begin + j, corner);
                     V wt = {};
                     for (int az = 0; az < 2; ++az)
                       for (int ay = 0; ay < 2; ++ay) {
                         const V yz = y2[ay] + z2[az];
                         for (int ax = 0; ax < 2; ++ax) {
                           const V q = positivePart(reach_x[ax] - yz);
                           wt += (wx[ax] * wy[ay] * wz[az] * corner[(az * 2 + ay) * 2 + ax]) *
                                 nodeKernel(q, ka, kb);
                         }
                       }
                     return wt;
                   });
}

/// The own strand's share of eq. (10)'s sums as exact pairs in single precision
/// (ownSharesInLanes) over the strand's count particles: w_ij = W(|p_i - p_j|), i included
/// (W(0) V_i).
void exactOwnSharesSingle(const Lattice& L, const OwnPairArrays& a, int count) {
  typedef OwnLanes V;
  const float* __restrict tx = a.tx;
  const float* __restrict ty = a.ty;
  const float* __restrict tz = a.tz;
  const float h2 = static_cast<float>(double(L.cells * L.cells));
  ownSharesInLanes(a, count, true, [&](int j, const V& ex, const V& ey, const V& ez) {
    const V dx = ex + tx[j], dy = ey + ty[j], dz = ez + tz[j];
    const V q = positivePart(h2 - (dx * dx + dy * dy + dz * dz));
    return q * q * q;
  });
}

/// The splat's particles in two halves by index, each added into its own copy of the node
/// arrays; the caller sums the copies node by node (half 0 + half 1). Two threads then each take
/// one half and read only its particles: with one copy, each thread owned a slab of node layers
/// and scanned every particle for those in its slab, and the splats ran 1.2x faster on 2
/// threads than on 1.
constexpr int kSplatHalves = 2;

/// The particles of one half: [begin, end).
inline std::pair<int, int> splatHalf(int half, int n) {
  return half == 0 ? std::make_pair(0, n / 2) : std::make_pair(n / 2, n);
}

/// Splats every particle of p onto the 8 nodes of its cell: particle(j, cell, half, owner) gives
/// the particle's adder for its half's copy of the node arrays (kSplatHalves), called as add(node,
/// t) for each corner node with its trilinear weight t, so that the particle's values are read
/// once, not once per corner. A particle whose cell spans two threads' layers is visited by both;
/// `owner` is true on exactly one visit (the thread holding the cell's lower layer), the one that
/// may store per-particle values. One thread does both halves in turn; a team gives each half its
/// share of the threads, and a half's threads split its node layers kz evenly, each scanning the
/// half's particles in order and adding only to its own layers.
/// Every node of a copy receives its additions in particle order, as in a serial loop, so the
/// lattice is bit-identical for any thread count.
template <typename Particle>
void splat(const Lattice& L, const Vec3List& p, int threads, Particle particle) {
  static_assert(kSplatHalves == 2, "the team is split in two below, as are splatHalf's ranges");
  const int n = static_cast<int>(p.size());
  parallelRegion(threads, [&](int64_t t, int64_t team) {
    for (int half = 0; half < kSplatHalves; ++half) {
      // The half's threads: all of a team of one, else the first or the second half of the team.
      const int64_t first = team == 1 || half == 0 ? 0 : team / 2;
      const int64_t count = team == 1 ? 1 : (half == 0 ? team / 2 : team - team / 2);
      const int64_t rank = t - first;
      if (rank < 0 || rank >= count) continue;
      const int64_t z_lo = L.nz * rank / count, z_hi = L.nz * (rank + 1) / count;
      const std::pair<int, int> range = splatHalf(half, n);
      for (int j = range.first; j < range.second; ++j) {
        const int64_t cz = static_cast<int64_t>(std::floor(nodeCoordinate(L, p[j], 2)));
        if (cz + 1 < z_lo || cz >= z_hi) continue;
        const CellPosition cell = cellPosition(L, p[j]);
        const int64_t cx = static_cast<int64_t>(cell.k[0]), cy = static_cast<int64_t>(cell.k[1]);
        const double tx = cell.t[0], ty = cell.t[1], tz = cell.t[2];
        auto add = particle(j, cell, half, cz >= z_lo);
        for (int az = 0; az < 2; ++az) {
          const int64_t kz = cz + az;
          if (kz < z_lo || kz >= z_hi) continue;
          const double wz = az ? tz : 1.0 - tz;
          for (int ay = 0; ay < 2; ++ay) {
            const double wy = ay ? ty : 1.0 - ty;
            const int64_t row = L.index(cx, cy + ay, kz);
            add(row, (1.0 - tx) * wy * wz);
            add(row + 1, tx * wy * wz);
          }
        }
      }
    }
  });
}

/// Pass 2's adder for particle j: V onto a corner node, and V sigma and V sigma (p - x_ref)
/// (WetNodes) as one vector onto the node's 4 entries of the side-by-side array, formed once per
/// particle.
struct WetSplat {
  typedef double Quad __attribute__((vector_size(32), aligned(8)));
  double* __restrict volume;
  double* __restrict wet;  ///< 4 per node: V sigma, V sigma (p - x_ref)
  double v, vs;
  Quad particle;  ///< V sigma (1, p - x_ref)
  WetSplat(double* volume_nodes, double* wet_nodes, double volume_j, double wet_share_j,
           const Vec3& from_reference)
      : volume(volume_nodes),
        wet(wet_nodes),
        v(volume_j),
        vs(wet_share_j),
        particle(wet_share_j *
                 Quad{1.0, from_reference.x(), from_reference.y(), from_reference.z()}) {}
  void operator()(int64_t node, double t) const {
    volume[node] += t * v;
    if (vs == 0.0) return;
    Quad* q = reinterpret_cast<Quad*>(wet + 4 * node);
    *q += t * particle;
  }
};

/// The nodes [first, last) of a row from x_lo to x_hi that hold mass (in != 0), from the first
/// to the last one; first == last when none does.
inline std::pair<int64_t, int64_t> massSpan(const double* row, int64_t x_lo, int64_t x_hi) {
  int64_t first = x_lo, last = x_hi;
  while (first < x_hi && row[first] == 0.0) ++first;
  while (last > first && row[last - 1] == 0.0) --last;
  return {first, last};
}

/// The node kernel K(q) = q (q^2 + ka q + kb), q = h^2 - |v|^2 c^2, at the integer node offsets v
/// in [-kCells, kCells]^3 (0 beyond h): the one table the node convolutions and the lattice
/// functional's own-strand shares read, so both weigh a pair of nodes alike to the bit.
template <int kCells>
struct NodeTaps {
  static constexpr int kW = 2 * kCells + 1;
  double k[kW * kW * kW];
  NodeTaps(const Lattice& L, double ka, double kb) {
    const double h2 = L.h * L.h;
    for (int dz = -kCells; dz <= kCells; ++dz)
      for (int dy = -kCells; dy <= kCells; ++dy)
        for (int dx = -kCells; dx <= kCells; ++dx) {
          const double q = h2 - L.c * L.c * double(dx * dx + dy * dy + dz * dz);
          k[index(dx, dy, dz)] = q > 0.0 ? nodeKernel(q, ka, kb) : 0.0;
        }
  }
  static int index(int dx, int dy, int dz) {
    return ((dz + kCells) * kW + dy + kCells) * kW + dx + kCells;
  }
  /// K at any integer offset: 0 where a component exceeds kCells (beyond h).
  double at(int dx, int dy, int dz) const {
    const bool inside = std::abs(dx) <= kCells && std::abs(dy) <= kCells && std::abs(dz) <= kCells;
    return inside ? k[index(dx, dy, dz)] : 0.0;
  }
};

/// out_n = sum_m K(|x_n - x_m|) in_m over the nodes m within h of n (NodeTaps), kStride doubles
/// per node side by side (one array: the mass; or the wet splat's S, Px, Py, Pz), at every node
/// with mass (mass_n != 0) whose window lies inside the lattice: the nodes of every particle's
/// cell do (the lattice's margin is kCells + 2 nodes). Only those are read: a particle takes the
/// corners of its cell, each of which holds its mass unless its trilinear weight is 0, and the
/// node volumes divide where there is mass. So each row is convolved in blocks of 8 nodes from
/// its first node with mass to its last (about a fifth of the hair's bounding box holds mass at
/// 10,000 strands, 3 nodes per radius); a block may run up to 7 nodes past the last, into nodes
/// no particle reads (the lattice's margin and padding), and nodes outside the blocks keep
/// whatever they held. A block sums every tap into registers and is stored once (adding each tap
/// into the output row in memory cost a load and a store per tap and node); every node sums its
/// taps in the same order whatever the thread count, layers shared among the threads one at a time
/// (the mass is uneven along z: static halves of the layers left one thread waiting).
template <int kCells, int kStride>
void convolveNodeBlocks(const Lattice& L, const double* __restrict mass,
                        const double* __restrict in, double* __restrict out,
                        const NodeTaps<kCells>& taps, int threads) {
  typedef Lanes<double>::type D;
  constexpr int kBlock = 8, kVectors = kBlock * kStride / kDoubleLanes;
  constexpr int kW = NodeTaps<kCells>::kW;
  int64_t offset[kW * kW * kW];  // the taps within h, as node offsets, and their weights
  double weight[kW * kW * kW];
  int count = 0;
  for (int dz = -kCells; dz <= kCells; ++dz)
    for (int dy = -kCells; dy <= kCells; ++dy)
      for (int dx = -kCells; dx <= kCells; ++dx) {
        if (taps.at(dx, dy, dz) == 0.0) continue;
        offset[count] = kStride * ((dz * L.ny + dy) * L.nx + dx);
        weight[count++] = taps.at(dx, dy, dz);
      }
  const int64_t x_lo = kCells, x_hi = L.nx - kCells;
  parallelFor(threads, Schedule::kDynamic, 1, L.nz - 2 * kCells, [&](int64_t layer) {
    const int64_t kz = layer + kCells;
    for (int64_t ky = kCells; ky < L.ny - kCells; ++ky) {
      const int64_t row_start = L.index(0, ky, kz);
      const auto [lo, hi] = massSpan(mass + row_start, x_lo, x_hi);
      for (int64_t x = lo; x < hi; x += kBlock) {
        const double* from = in + kStride * (row_start + x);
        D sum[kVectors] = {};
        for (int t = 0; t < count; ++t)
          for (int v = 0; v < kVectors; ++v)
            sum[v] += weight[t] * loadLanes<D>(from + offset[t] + kDoubleLanes * v);
        std::memcpy(out + kStride * (row_start + x), sum, sizeof sum);
      }
    }
  });
}

/// sum_n t_n a_n over the 8 nodes of a particle's cell (trilinear weights t_n).
WCH_INLINE double interpolateNodes(const Lattice& L, const CellPosition& cell, const double* a) {
  const int64_t n = L.index(static_cast<int64_t>(cell.k[0]), static_cast<int64_t>(cell.k[1]),
                            static_cast<int64_t>(cell.k[2]));
  const int64_t up = L.nx * L.ny;
  const double tx = cell.t[0], ty = cell.t[1], tz = cell.t[2];
  auto along_x = [&](int64_t k) { return (1.0 - tx) * a[k] + tx * a[k + 1]; };
  const double low = (1.0 - ty) * along_x(n) + ty * along_x(n + L.nx);
  const double high = (1.0 - ty) * along_x(n + up) + ty * along_x(n + up + L.nx);
  return (1.0 - tz) * low + tz * high;
}

/// The wet splat's halves summed (splat) and spread into the node arrays the gathers read: the
/// volume into scalar, the side-by-side splat (wet_splat, 4 per node) into wet_volume, qx, qy,
/// qz, and with `single` their float copies, in one pass over the nodes. With node volumes
/// (density_norm > 0: splatWithNodeVolumes) scalar holds the summed mass and wet_volume the node
/// densities over density_norm: every sum is divided by the node's density, whose inverse goes
/// to scalar_b (0 where no mass was splatted), and the halves of scalar are not summed again.
void spreadWetSplat(CohesionNodeGrid* g, int64_t nodes, bool single, double density_norm,
                    int threads) {
  const bool node_volumes = density_norm > 0.0;
  const double* __restrict w = g->wet_splat.data();
  const double* __restrict w_b = g->wet_splat_b.data();
  double* __restrict v = g->scalar.data();
  double* __restrict v_b = g->scalar_b.data();
  float* __restrict vf = g->scalar_f.data();
  double* __restrict s = g->wet_volume.data();
  double* __restrict x = g->qx.data();
  double* __restrict y = g->qy.data();
  double* __restrict z = g->qz.data();
  float* __restrict sf = g->wet_volume_f.data();
  float* __restrict xf = g->qx_f.data();
  float* __restrict yf = g->qy_f.data();
  float* __restrict zf = g->qz_f.data();
  parallelFor(threads, Schedule::kStatic, 0, nodes, [&](int64_t k) {
    double f = 1.0;  // the node's inverse density with node volumes; exact otherwise
    if (node_volumes) {
      const double density = density_norm * s[k];
      f = v[k] > 0.0 && density > 0.0 ? 1.0 / density : 0.0;
      v_b[k] = f;
      v[k] *= f;
    } else {
      v[k] += v_b[k];
    }
    s[k] = (w[4 * k] + w_b[4 * k]) * f;
    x[k] = (w[4 * k + 1] + w_b[4 * k + 1]) * f;
    y[k] = (w[4 * k + 2] + w_b[4 * k + 2]) * f;
    z[k] = (w[4 * k + 3] + w_b[4 * k + 3]) * f;
    if (!single) return;
    vf[k] = static_cast<float>(v[k]);
    sf[k] = static_cast<float>(s[k]);
    xf[k] = static_cast<float>(x[k]);
    yf[k] = static_cast<float>(y[k]);
    zf[k] = static_cast<float>(z[k]);
  });
}

/// The wet splat's halves summed into the first (volume and wet sums), for the sums convolved at
/// the nodes (spreadWetSplat's pass for the gathers).
void sumSplatHalves(CohesionNodeGrid* g, int64_t nodes, int threads) {
  double* __restrict v = g->scalar.data();
  const double* __restrict v_b = g->scalar_b.data();
  double* __restrict w = g->wet_splat.data();
  const double* __restrict w_b = g->wet_splat_b.data();
  parallelFor(threads, Schedule::kStatic, 0, nodes, [&](int64_t k) {
    v[k] += v_b[k];
    for (int c = 0; c < 4; ++c) w[4 * k + c] += w_b[4 * k + c];
  });
}

/// The first `count` entries of each of a and b set to 0.
void zero(std::vector<double>* a, std::vector<double>* b, int64_t count, int threads) {
  double* __restrict x = a->data();
  double* __restrict y = b->data();
  parallelFor(threads, Schedule::kStatic, 0, count, [&](int64_t k) {
    x[k] = 0.0;
    y[k] = 0.0;
  });
}

/// a += b over the first `count` entries.
void addInto(std::vector<double>* a, const std::vector<double>& b, int64_t count, int threads) {
  double* __restrict x = a->data();
  const double* __restrict y = b.data();
  parallelFor(threads, Schedule::kStatic, 0, count, [&](int64_t k) { x[k] += y[k]; });
}

/// Splats particle j's values onto its half's copies (WetSplat): volume v and wet share vs.
inline WetSplat wetSplat(CohesionNodeGrid* g, const Lattice& L, const CellPosition& cell, int half,
                         double v, double vs) {
  return WetSplat(half == 0 ? g->scalar.data() : g->scalar_b.data(),
                  half == 0 ? g->wet_splat.data() : g->wet_splat_b.data(), v, vs,
                  cell.r - L.reference);
}

/// The density rho = norm sum_j m_j W(|x - p_j|) of eq. (10)'s volumes, from the node sums.
inline double densityNorm(double h) { return 315.0 / (64.0 * M_PI * std::pow(h, 9)); }

/// The splatted mass's halves summed (scalar) and the density at the nodes convolved with the
/// node kernel (ka, kb) into wet_volume (unnormalised: densityNorm), which it returns.
template <int kCells>
const double* nodeDensities(const Lattice& L, int64_t nodes, double ka, double kb,
                            CohesionNodeGrid* g, int threads) {
  addInto(&g->scalar, g->scalar_b, nodes, threads);
  double* const node_density = g->wet_volume.data();
  convolveNodeBlocks<kCells, 1>(L, g->scalar.data(), g->scalar.data(), node_density,
                                NodeTaps<kCells>(L, ka, kb), threads);
  return node_density;
}

/// A particle's density from its cell's nodes (nodeDensities' array; norm: densityNorm), and
/// its volume V = m / rho.
struct ParticleDensity {
  double density, volume;
};
WCH_INLINE ParticleDensity particleDensity(const Lattice& L, const CellPosition& cell,
                                           const double* node_density, double norm, double mass) {
  const double density = norm * interpolateNodes(L, cell, node_density);
  return ParticleDensity{density, mass / density};
}

/// The node arrays of eq. (10) with the particle volumes V_j = m_j / rho_j: pass 1 splats the
/// mass (the two halves' copies summed); the density at the nodes, then at every particle from
/// its cell's nodes (the lattice's density field is smooth on the scale h: convolving once per
/// node and interpolating costs a fraction of a gather per particle, at 1.02x its error against
/// exact, docs/physics.md 7.3), followers included with gather_at "guides", taken by pass 2 as
/// it splats V, V sigma and V sigma (p - x_ref). Pass 2 writes its node arrays' other copies: the
/// node densities it reads are in wet_volume.
template <int kCells>
NodeVolumes splatWithParticleVolumes(const HairModel& model, const Lattice& L, int64_t nodes,
                                     int gathered, bool single, bool node_sums, HairState* state,
                                     int threads) {
  CohesionNodeGrid& g = state->cohesion_grid;
  const Vec3List& p = state->position;
  zero(&g.scalar, &g.scalar_b, nodes, threads);
  double* const mass_nodes[kSplatHalves] = {g.scalar.data(), g.scalar_b.data()};
  splat(L, p, threads, [&](int j, const CellPosition&, int half, bool) {
    const double m = model.mass_kg[j];
    double* const nodes_of_half = mass_nodes[half];
    return [m, nodes_of_half](int64_t node, double t) { nodes_of_half[node] += t * m; };
  });
  const double* const node_density =
      nodeDensities<kCells>(L, nodes, L.ka_both, L.kb_both, &g, threads);
  const double norm = densityNorm(L.h);
  zero(&g.scalar, &g.scalar_b, nodes, threads);
  zero(&g.wet_splat, &g.wet_splat_b, 4 * nodes, threads);
  // Pass 2 takes each particle's density from its cell's nodes as it splats it (a pass of their
  // own would read the positions and masses again and store the volumes only for this one to
  // read them back). Its owning visit stores what the later passes read: the volume (the own-strand
  // shares and include_self), the density with the gathers, and the gathered strands' V sigma for
  // their own-strand shares (with gather_at "guides" the followers' would be written and never
  // read). The node sums form their V sigma a strand at a time (strandOwnPairArrays,
  // latticeOwnShare).
  splat(L, p, threads, [&](int j, const CellPosition& cell, int half, bool owner) {
    const ParticleDensity d = particleDensity(L, cell, node_density, norm, model.mass_kg[j]);
    const double wet_share = d.volume * state->saturation[j];
    if (owner) {
      g.volume[j] = d.volume;
      if (!node_sums) {
        state->density[j] = d.density;
        if (j < gathered) {
          g.wet_share[j] = wet_share;
          if (single) {
            g.volume_f[j] = static_cast<float>(d.volume);
            g.wet_share_f[j] = static_cast<float>(wet_share);
          }
        }
      }
    }
    return wetSplat(&g, L, cell, half, d.volume, wet_share);
  });
  // The sums convolved at the nodes take the two halves as the splat left them.
  if (!node_sums) spreadWetSplat(&g, nodes, single, 0.0, threads);
  return NodeVolumes{};
}

/// The node arrays of eq. (10) with the node volumes (CohesionConfig::grid_node_volumes): one
/// splat of m, m sigma and m sigma (p - x_ref); the density at the nodes from the mass, each node's
/// sums divided by it (spreadWetSplat), and the gathered particles' densities (their own weight,
/// include_self) from their cells' nodes. The node densities pass one trilinear interpolation
/// (the splat), not two: the kernel's correction once (L.ka, L.kb). The followers' densities
/// (HairState::density) are not computed with gather_at "guides".
template <int kCells>
NodeVolumes splatWithNodeVolumes(const HairModel& model, const Lattice& L, int64_t nodes,
                                 int gathered, bool single, HairState* state, int threads) {
  CohesionNodeGrid& g = state->cohesion_grid;
  const Vec3List& p = state->position;
  zero(&g.scalar, &g.scalar_b, nodes, threads);
  zero(&g.wet_splat, &g.wet_splat_b, 4 * nodes, threads);
  splat(L, p, threads, [&](int j, const CellPosition& cell, int half, bool) {
    const double m = model.mass_kg[j];
    return wetSplat(&g, L, cell, half, m, m * state->saturation[j]);
  });
  const double* const node_density = nodeDensities<kCells>(L, nodes, L.ka, L.kb, &g, threads);
  const double norm = densityNorm(L.h);
  parallelFor(threads, Schedule::kStatic, 0, gathered, [&](int i) {
    const ParticleDensity d =
        particleDensity(L, cellPosition(L, p[i]), node_density, norm, model.mass_kg[i]);
    state->density[i] = d.density;
    g.volume[i] = d.volume;
    g.wet_share[i] = state->saturation[i];  // the corner factors carry m / rho_n
    if (!single) return;
    g.volume_f[i] = static_cast<float>(g.volume[i]);
    g.wet_share_f[i] = static_cast<float>(g.wet_share[i]);
  });
  spreadWetSplat(&g, nodes, single, densityNorm(L.h), threads);
  return NodeVolumes{g.scalar_b.data(), model.mass_kg.data()};
}

}  // namespace

namespace {

/// Below this ratio of other-strand to own-strand weight the float gather is redone in double.
/// The float error of p^w grows as (own / other) weight: at 1e-3 the AVX2 build (one row per
/// 8-float vector at 3 nodes per radius) reached 16.7 um without the particle's own weight, 1.2 %
/// of the lattice's own max error; at 1e-2, 0.61 um. It takes 146 of 576,000 wet particle-frames
/// of 0.3 s of the 1,000-strand scene fully wet (70 at 1e-3), none at 10,000 strands, K = 10.
constexpr double kSingleGuard = 1e-2;

/// Eq. (10)'s display offset of particle i from its sums over all strands and over its own
/// strand (the own share subtracted, A13; self_weight V_i W(0) added back with include_self),
/// written as p^w (dry particles, gathered with gather_at "guides" for their offsets, keep p^w =
/// p). Returns 1 when the particle moved.
WCH_INLINE int writeClumpOffset(const CohesionConfig& cfg, const WetSums& all, const WetSums& own,
                                double self_weight, bool wet_particle, bool at_guides, int i,
                                const Vec3& p, const detail::DisplayWrite& write,
                                HairState* state) {
  double weight_sum = all.weight - own.weight;
  // Round-off of the cancellation: no other strand within reach.
  if (!(weight_sum > 1e-9 * own.weight)) {
    if (at_guides) state->guide_clump_offset[i] = Vec3::Zero();
    write.unmoved(i, p);
    return 0;
  }
  const Vec3 pull = all.pull - own.pull;
  if (cfg.include_self) weight_sum += self_weight;
  const Vec3 offset = clumpOffset(pull, weight_sum, cfg.tightness);
  if (at_guides) state->guide_clump_offset[i] = offset;
  if (!wet_particle) {
    write.unmoved(i, p);
    return 0;
  }
  write(i, p, offset);
  return 1;
}

/// With grid_wet_sums "nodes": the own strand is subtracted as exact pairs where the other strands'
/// weight exceeds this many times the own strand's (there the lattice's error on the own share,
/// a few % of it, is below a fifth of that of the sums it is taken from), else through the lattice
/// functional itself, which cancels an isolated strand to round-off.
constexpr double kExactOwnRatio = 4.0;

/// The node sums of eq. (10) with grid_wet_sums "nodes", convolved (sum_m K(x_n - x_m) of each):
/// V per node, and S, Px, Py, Pz side by side (4 per node, as the wet splat adds them).
struct ConvolvedWetNodes {
  const double* volume;
  const double* wet;
};

/// The sums of eq. (10) at a particle from its cell's 8 convolved nodes (trilinear), as WetSums:
/// a cell's two nodes along x hold 8 consecutive wet sums, one vector with AVX-512 and two
/// without (kDoubleLanes); the volume as the densities take theirs (interpolateNodes).
WCH_INLINE WetSums interpolateWetSums(const Lattice& L, const ConvolvedWetNodes& c,
                                      const CellPosition& cell) {
  typedef Lanes<double>::type D;
  constexpr int kPieces = 8 / kDoubleLanes;
  const int64_t n = L.index(static_cast<int64_t>(cell.k[0]), static_cast<int64_t>(cell.k[1]),
                            static_cast<int64_t>(cell.k[2]));
  const int64_t up = L.nx * L.ny;
  const double tx = cell.t[0], ty = cell.t[1], tz = cell.t[2];
  const int64_t corner[4] = {n, n + L.nx, n + up, n + up + L.nx};
  const double weight[4] = {(1.0 - ty) * (1.0 - tz), ty * (1.0 - tz), (1.0 - ty) * tz, ty * tz};
  D along_x[kPieces], wet[kPieces] = {};  // entry e of the 8: the low node's below 4
  for (int e = 0; e < 8; ++e) along_x[e / kDoubleLanes][e % kDoubleLanes] = e < 4 ? 1.0 - tx : tx;
  for (int k = 0; k < 4; ++k)
    for (int h = 0; h < kPieces; ++h)
      wet[h] += (weight[k] * along_x[h]) * loadLanes<D>(c.wet + 4 * corner[k] + kDoubleLanes * h);
  double sum[8];
  std::memcpy(sum, wet, sizeof sum);
  return wetSums(L, cell.r, interpolateNodes(L, cell, c.volume), sum[0] + sum[4],
                 Vec3(sum[1] + sum[5], sum[2] + sum[6], sum[3] + sum[7]));
}

/// The own strand's share through the lattice functional of the convolved nodes: for particle j
/// of the strand, sum over the corners d of i's cell and c of j's of t_id t_jc K(x_c - x_d), the
/// weight the splat, the convolution and the interpolation give j at p_i. Along each axis c - d
/// takes the cell difference plus -1, 0 or 1, so the 64 corner pairs fold into 27 offsets.
template <int kCells>
WetSums latticeOwnShare(const Lattice& L, const NodeTaps<kCells>& taps, const CohesionNodeGrid& g,
                        const Vec3List& p, const double* saturation, int begin, int end, int i) {
  const Vec3 ri = cellPosition(L, p[i]).r;
  const CellAxis ci[3] = {cellAxis(L, ri.x()), cellAxis(L, ri.y()), cellAxis(L, ri.z())};
  WetSums share;
  for (int j = begin; j < end; ++j) {
    const Vec3 rj = cellPosition(L, p[j]).r;
    int delta[3];
    double fold[3][3];  // per axis, the weight of c - d = delta - 1, delta, delta + 1
    for (int a = 0; a < 3; ++a) {
      const CellAxis cj = cellAxis(L, rj[a]);
      delta[a] = static_cast<int>(cj.node - ci[a].node);
      const double ti = ci[a].fraction, tj = cj.fraction;
      fold[a][0] = (1.0 - tj) * ti;                    // c at j's low node, d at i's high
      fold[a][1] = (1.0 - tj) * (1.0 - ti) + tj * ti;  // both low, both high
      fold[a][2] = tj * (1.0 - ti);                    // c high, d low
    }
    double w = 0.0;
    for (int ez = 0; ez < 3; ++ez)
      for (int ey = 0; ey < 3; ++ey)
        for (int ex = 0; ex < 3; ++ex)
          w += fold[0][ex] * fold[1][ey] * fold[2][ez] *
               taps.at(delta[0] + ex - 1, delta[1] + ey - 1, delta[2] + ez - 1);
    share.weight += g.volume[j] * w;
    share.pull += (g.volume[j] * saturation[j] * w) * Vec3(rj - ri);
  }
  return share;
}

/// The own-pair arrays of strand [begin, end) in the thread's scratch (its lane storage, free
/// during the display pass, holds 12 (n + kCohesionFloatLanes) floats for any strand of n
/// particles: StrandScratch::resize): each particle's cell and fractions in float
/// (storeFloatCell's values), its volume and wet share V sigma in float, zeros in the
/// kCohesionFloatLanes past the end, and room for the shares.
OwnPairArrays strandOwnPairArrays(const Lattice& L, const CohesionNodeGrid& g,
                                  const HairState& state, int begin, int end,
                                  StrandScratch* scratch) {
  const int n = end - begin, room = n + kCohesionFloatLanes;
  float* f = reinterpret_cast<float*>(scratch->lane_buffer.data());
  float* column[12];
  for (int c = 0; c < 12; ++c) column[c] = f + static_cast<size_t>(c) * room;
  for (int k = 0; k < n; ++k) {
    const int i = begin + k;
    storeFloatCell(cellPosition(L, state.position[i]), column, k);
    column[6][k] = static_cast<float>(g.volume[i]);
    column[7][k] = static_cast<float>(g.volume[i] * state.saturation[i]);
  }
  for (int c = 0; c < 8; ++c) std::fill(column[c] + n, column[c] + room, 0.0f);
  return {column[0], column[1], column[2], column[3], column[4],  column[5],
          column[6], column[7], column[8], column[9], column[10], column[11]};
}

/// Eq. (10)'s sums at the gathered particles from the convolved nodes (grid_wet_sums "nodes"),
/// the own strand subtracted (kExactOwnRatio), written as in evaluateOnLattice. Returns the
/// number of particles moved.
template <int kCells>
int displayFromConvolvedNodes(const HairModel& model, const CohesionConfig& cfg, const Lattice& L,
                              HairState* state, int gathered, int gathered_strands, bool at_guides,
                              int threads) {
  CohesionNodeGrid& g = state->cohesion_grid;
  const Vec3List& p = state->position;
  const double h2 = cfg.radius_m * cfg.radius_m;
  const NodeTaps<kCells> taps(L, L.ka_both, L.kb_both);
  // The splat's halves summed in place (V in scalar, S and P side by side in wet_splat), and
  // convolved into qx and wet_splat_b.
  const int64_t nodes = L.nx * L.ny * L.nz;
  sumSplatHalves(&g, nodes, threads);
  convolveNodeBlocks<kCells, 1>(L, g.scalar.data(), g.scalar.data(), g.qx.data(), taps, threads);
  convolveNodeBlocks<kCells, 4>(L, g.scalar.data(), g.wet_splat.data(), g.wet_splat_b.data(), taps,
                                threads);
  const ConvolvedWetNodes convolved{g.qx.data(), g.wet_splat_b.data()};
  const double c6 = std::pow(L.c, 6);
  const detail::DisplayWrite write = detail::displayWrite(cfg, state);
  // A strand at a time: its cells and own shares in the thread's scratch, then its particles'
  // sums, so that none of them goes to memory (stored per particle by the earlier passes and read
  // back here, they moved about 150 bytes per particle).
  return static_cast<int>(parallelSum(threads, 16, gathered_strands, [&](int s) -> int {
    const int begin = model.strandBegin(s), end = begin + model.strandSize(s);
    bool wet_strand = at_guides;
    for (int i = begin; i < end && !wet_strand; ++i) wet_strand = state->saturation[i] > 0.0;
    if (!wet_strand) {  // dry particles keep p^w = p
      for (int i = begin; i < end; ++i) write.unmoved(i, p[i]);
      return 0;
    }
    const OwnPairArrays own_pairs =
        strandOwnPairArrays(L, g, *state, begin, end, &state->scratch[detail::threadIndex()]);
    exactOwnSharesSingle(L, own_pairs, end - begin);
    int moved = 0;
    for (int i = begin; i < end; ++i) {
      const bool wet_particle = state->saturation[i] > 0.0;
      if (!wet_particle && !at_guides) {
        write.unmoved(i, p[i]);
        continue;
      }
      const WetSums all = interpolateWetSums(L, convolved, cellPosition(L, p[i]));
      WetSums own;
      const int k = i - begin;
      own.weight = c6 * double(own_pairs.weight[k]);
      own.pull = (c6 * L.c) * Vec3(own_pairs.px[k], own_pairs.py[k], own_pairs.pz[k]);
      if (!(all.weight - own.weight > kExactOwnRatio * own.weight))
        own = latticeOwnShare<kCells>(L, taps, g, p, state->saturation.data(), begin, end, i);
      moved += writeClumpOffset(cfg, all, own, g.volume[i] * poly6Shape(0.0, h2), wet_particle,
                                at_guides, i, p[i], write, state);
    }
    return moved;
  }));
}

template <int kCells>
int evaluateOnLattice(const HairModel& model, const CohesionConfig& cfg, const Lattice& L,
                      int64_t nodes, bool node_sums, HairState* state, int threads) {
  CohesionNodeGrid& g = state->cohesion_grid;
  const Vec3List& p = state->position;
  const int n = model.particleCount();
  const double h = cfg.radius_m, h2 = h * h;
  const bool single = cfg.grid_single_precision && !node_sums;
  // With gather_at "guides" the sums of eq. (10) run over the guide particles only (wet or dry:
  // wet followers interpolate their display offsets); every particle is still splatted.
  const int guide_strands = model.followers.guide_strands;
  const bool at_guides = cfg.gather_at == "guides" && guide_strands > 0;
  const int gathered = at_guides ? static_cast<int>(model.strandBegin(guide_strands)) : n;
  const int gathered_strands = at_guides ? guide_strands : model.strandCount();
  // The gathered strands' particles' positions on the lattice, stored for their gathers and
  // own-strand shares, with their cells and trilinear fractions in float for the float shares
  // (the passes over every particle compute them from the positions: cellPosition).
  // The node sums store neither: they form each strand's float cells in the thread's scratch
  // (strandOwnPairArrays) and latticeOwnShare its positions.
  if (!node_sums) {
    float* const float_cells[6] = {g.kx_f.data(), g.ky_f.data(), g.kz_f.data(),
                                   g.tx_f.data(), g.ty_f.data(), g.tz_f.data()};
    parallelFor(threads, Schedule::kStatic, 0, gathered, [&](int j) {
      const CellPosition cell = cellPosition(L, p[j]);
      g.rx[j] = cell.r.x();
      g.ry[j] = cell.r.y();
      g.rz[j] = cell.r.z();
      if (single) storeFloatCell(cell, float_cells, j);  // read by the float own shares only
    });
  }

  const NodeVolumes volumes =
      cfg.grid_node_volumes
          ? splatWithNodeVolumes<kCells>(model, L, nodes, gathered, single, state, threads)
          : splatWithParticleVolumes<kCells>(model, L, nodes, gathered, single, node_sums, state,
                                             threads);
  if (node_sums) {
    const int clumped = displayFromConvolvedNodes<kCells>(model, cfg, L, state, gathered,
                                                          gathered_strands, at_guides, threads);
    return at_guides ? clumped + displayFollowersFromGuides(model, cfg, state, threads) : clumped;
  }
  const WetNodes<double> wet{g.scalar.data(), g.wet_volume.data(), g.qx.data(), g.qy.data(),
                             g.qz.data()};
  // The own strands' shares in float, a strand at a time (strands with a wet particle only;
  // every guide with gather_at "guides").
  if (single) {
    parallelFor(threads, Schedule::kDynamic, 16, gathered_strands, [&](int s) {
      const int begin = model.strandBegin(s), end = begin + model.strandSize(s);
      bool wet_strand = at_guides;
      for (int i = begin; i < end && !wet_strand; ++i) wet_strand = state->saturation[i] > 0.0;
      if (!wet_strand) return;
      if (volumes.inverse_density)
        ownStrandSharesSingle<true>(L, &g, volumes, begin, end);
      else
        ownStrandSharesSingle<false>(L, &g, volumes, begin, end);
    });
  }
  const double c6 = L.c * L.c * L.c * L.c * L.c * L.c;  // the float shares' lattice units
  const WetNodes<float> wet_f{g.scalar_f.data(), g.wet_volume_f.data(), g.qx_f.data(),
                              g.qy_f.data(), g.qz_f.data()};
  auto ownStrandShareOf = [&](int begin, int end, int i) {
    return volumes.inverse_density ? ownStrandShare<true>(L, g, volumes, begin, end, i, h2)
                                   : ownStrandShare<false>(L, g, volumes, begin, end, i, h2);
  };
  const detail::DisplayWrite write = detail::displayWrite(cfg, state);
  const int clumped = static_cast<int>(parallelSum(threads, 256, gathered, [&](int i) -> int {
    const bool wet_particle = state->saturation[i] > 0.0;
    if (!wet_particle && !at_guides) {  // dry particles keep p^w = p
      write.unmoved(i, p[i]);
      return 0;
    }
    // All strands: sum_n W_in V_n and the pull sum_n W_in P_n - (p_i - x_ref) sum_n W_in S_n.
    const Vec3 ri(g.rx[i], g.ry[i], g.rz[i]);
    WetSums all =
        single ? gatherWetSingle<kCells>(L, wet_f, ri, h2) : gatherWet<kCells>(L, wet, ri, h2);
    // The own strand (particle i included) through the same functional, subtracted.
    const int s = static_cast<int>(state->grid.strand_of[i]);
    const int begin = model.strandBegin(s), end = begin + model.strandSize(s);
    WetSums own;
    if (single) {
      own.weight = c6 * double(g.own_weight_f[i]);
      own.pull = (c6 * L.c) * Vec3(g.own_px_f[i], g.own_py_f[i], g.own_pz_f[i]);
    } else {
      own = ownStrandShareOf(begin, end, i);
    }
    // Float round-off in either sum is ~1e-6 of it: where the other strands' share is below
    // kSingleGuard of the own strand's it would be a large part of the difference; both again in
    // double there.
    if (single && !(all.weight - own.weight > kSingleGuard * own.weight)) {
      all = gatherWet<kCells>(L, wet, ri, h2);
      own = ownStrandShareOf(begin, end, i);
    }
    return writeClumpOffset(cfg, all, own, g.volume[i] * poly6Shape(0.0, h2), wet_particle,
                            at_guides, i, p[i], write, state);
  }));
  return at_guides ? clumped + displayFollowersFromGuides(model, cfg, state, threads) : clumped;
}

/// The positions' bounding box, on every thread: each takes a contiguous share, and the shares'
/// boxes are joined in thread order (min and max are exact: the same box for any thread count).
/// A non-finite coordinate anywhere makes the box NaN (min and max alone would skip it), so
/// that the lattice is refused rather than indexed with it.
void boundingBox(const Vec3List& p, int threads, Vec3* lo, Vec3* hi) {
  const int64_t n = static_cast<int64_t>(p.size());
  Vec3 share_lo[kMaxSolverThreads], share_hi[kMaxSolverThreads];
  bool share_finite[kMaxSolverThreads];
  int64_t shares = 1;
  parallelRegion(std::min(threads, kMaxSolverThreads), [&](int64_t t, int64_t team) {
    if (t == 0) shares = team;
    const int64_t begin = n * t / team, end = n * (t + 1) / team;
    // The share's coordinates as one run of doubles, 8 particles (24 coordinates) at a time:
    // coordinate j of every chunk is the same axis (j % 3), so 24 running minima and maxima
    // vectorise, and non-finite values are counted without a branch (|x| <= max is false for
    // them). Particle by particle in Eigen's 3-vectors it took 3.3 ns a particle.
    constexpr int kChunk = 24;
    double lo_run[kChunk], hi_run[kChunk];
    std::fill(lo_run, lo_run + kChunk, INFINITY);
    std::fill(hi_run, hi_run + kChunk, -INFINITY);
    const double* __restrict x = p.data()->data() + 3 * begin;
    const int64_t coordinates = 3 * (end - begin), whole = coordinates / kChunk * kChunk;
    int64_t nonfinite = 0;
    for (int64_t k = 0; k < whole; k += kChunk)
      for (int j = 0; j < kChunk; ++j) {
        const double v = x[k + j];
        lo_run[j] = v < lo_run[j] ? v : lo_run[j];
        hi_run[j] = v > hi_run[j] ? v : hi_run[j];
        nonfinite += !(std::abs(v) <= std::numeric_limits<double>::max());
      }
    for (int64_t k = whole; k < coordinates; ++k) {
      const double v = x[k];
      const int j = static_cast<int>(k - whole);
      lo_run[j] = std::min(lo_run[j], v);
      hi_run[j] = std::max(hi_run[j], v);
      nonfinite += !(std::abs(v) <= std::numeric_limits<double>::max());
    }
    Vec3 a = Vec3::Constant(INFINITY), b = Vec3::Constant(-INFINITY);
    for (int j = 0; j < kChunk; ++j) {
      a[j % 3] = std::min(a[j % 3], lo_run[j]);
      b[j % 3] = std::max(b[j % 3], hi_run[j]);
    }
    share_lo[t] = a;
    share_hi[t] = b;
    share_finite[t] = nonfinite == 0;
  });
  *lo = share_lo[0];
  *hi = share_hi[0];
  bool finite = share_finite[0];
  for (int64_t t = 1; t < shares; ++t) {
    *lo = lo->cwiseMin(share_lo[t]);
    *hi = hi->cwiseMax(share_hi[t]);
    finite = finite && share_finite[t];
  }
  if (!finite) *lo = *hi = Vec3::Constant(NAN);
}

}  // namespace

double restParticlesPerCell(const HairModel& model, double h, int cells_per_radius) {
  const int n = model.particleCount();
  if (n == 0 || !(h > 0.0) || cells_per_radius < 1) return 0.0;
  const double inv_c = cells_per_radius / h;
  std::vector<int64_t> cells(static_cast<size_t>(n));
  for (int i = 0; i < n; ++i) {
    const Vec3& p = model.rest_position_head[i];
    int64_t key = 0;
    for (int a = 0; a < 3; ++a)  // 21 bits per axis: +-1e6 cells, a 40 km groom at 4 cm
      key = (key << 21) | ((static_cast<int64_t>(std::floor(p[a] * inv_c)) + (1 << 20)) & 0x1fffff);
    cells[static_cast<size_t>(i)] = key;
  }
  std::sort(cells.begin(), cells.end());
  const size_t occupied =
      static_cast<size_t>(std::unique(cells.begin(), cells.end()) - cells.begin());
  return double(n) / double(occupied);
}

CohesionLattice cohesionLattice(const HairModel& model, const CohesionConfig& c) {
  CohesionLattice lattice;
  lattice.cells_per_radius = c.grid_cells_per_radius;
  if (c.grid_node_volumes) return lattice;
  if (c.grid_wet_sums == "nodes") {
    lattice.node_sums = true;
  } else if (c.grid_wet_sums == "auto" && c.grid_cells_per_radius == 3 &&
             model.cohesion_rest_density_cells == c.grid_cells_per_radius &&
             model.cohesion_rest_particles_per_cell >= kNodeSumsParticlesPerCell) {
    lattice.node_sums = true;
  }
  return lattice;
}

size_t cohesionGridNodeBound(const HairModel& model, const SolverConfig& config) {
  const CohesionConfig& c = config.cohesion;
  if (c.evaluation != "grid" || model.strandCount() == 0) return 0;
  Vec3 lo = Vec3::Constant(INFINITY), hi = Vec3::Constant(-INFINITY);
  for (int s = 0; s < model.strandCount(); ++s) {
    lo = lo.cwiseMin(model.rest_position_head[model.strandBegin(s)]);
    hi = hi.cwiseMax(model.rest_position_head[model.strandBegin(s)]);
  }
  const Vec3 centre = 0.5 * (lo + hi);
  double root_radius = 0.0, longest = 0.0;
  for (int s = 0; s < model.strandCount(); ++s) {
    const int begin = model.strandBegin(s);
    root_radius = std::max(root_radius, (model.rest_position_head[begin] - centre).norm());
    double rest = 0.0;  // the sag-free rest lengths may differ from the groom's
    for (int i = begin; i + 1 < begin + model.strandSize(s); ++i) rest += model.rest_edge_m[i];
    longest = std::max(longest, std::max(rest, model.strand_length_m[s]));
  }
  const double extent = 2.0 * (root_radius + longest * (1.0 + config.stretch.strain_limit));
  const int cells = cohesionLattice(model, c).cells_per_radius;
  const double spacing = c.radius_m / cells;
  // The step's margin: (cells + 2) nodes below the box and (cells + 3) above it.
  const double per_axis = std::ceil(extent / spacing) + 2.0 * cells + 6.0;
  const double nodes = per_axis * per_axis * per_axis;
  if (!std::isfinite(nodes) || nodes > double(kMaxCohesionGridNodes)) return 0;
  return static_cast<size_t>(nodes);
}

int computeDisplayCohesionGrid(const HairModel& model, const CohesionConfig& cfg, HairState* state,
                               int threads) {
  CohesionNodeGrid& g = state->cohesion_grid;
  const Vec3List& p = state->position;
  const int n = model.particleCount();
  if (n == 0 || g.scalar.empty()) return -1;
  const double h = cfg.radius_m, h2 = h * h;
  const CohesionLattice lattice = cohesionLattice(model, cfg);
  const int cells = lattice.cells_per_radius;
  Lattice L;
  L.h = h;
  L.cells = cells;
  L.c = h / cells;
  L.inv_c = 1.0 / L.c;
  // Trilinear interpolation adds (c^2 / 2) t (1 - t) d2W/dx2 per axis, on average (c^2 / 12)
  // lap W: the nodes hold K = W - (c^2 / 12) lap W = q^3 + 3.5 c^2 q^2 - 2 c^2 h^2 q, whose
  // interpolant matches W to O(c^4) on average. Measured (docs/physics.md §7.3): RMS error 2.5x
  // smaller at 4 nodes per radius, 1.7x at 3, but 1.03x larger at 2 (c = h / 2 is too coarse for
  // the Taylor argument), where it is left out. The densities, convolved at the nodes and
  // interpolated to the particle, pass two interpolations: K = W - (c^2 / 6) lap W (with it
  // the p^w error against exact at 3 nodes per radius is 1.02x the particle gathers', without
  // it 1.21x; test_cohesion MatchesExactOnAWetCurlyScene).
  if (cells >= 3) {
    L.ka = 3.5 * L.c * L.c;
    L.kb = -2.0 * L.c * L.c * h2;
    L.ka_both = 2.0 * L.ka;
    L.kb_both = 2.0 * L.kb;
  }
  Vec3 lo, hi;
  boundingBox(p, threads, &lo, &hi);
  // Kernel reach plus the trilinear cell on both sides (and one node of slack for round-off).
  const int64_t margin = cells + 2;
  L.origin = lo - Vec3::Constant(double(margin) * L.c);
  const Vec3 span = (hi - L.origin) * L.inv_c;
  if (!span.allFinite() || span.maxCoeff() > 1e6) return -1;
  L.nx = static_cast<int64_t>(std::floor(span.x())) + margin + 2;
  L.ny = static_cast<int64_t>(std::floor(span.y())) + margin + 2;
  L.nz = static_cast<int64_t>(std::floor(span.z())) + margin + 2;
  const int64_t nodes = L.nx * L.ny * L.nz;
  L.reference = L.c * Vec3(double(L.nx / 2), double(L.ny / 2), double(L.nz / 2));
  // The arrays carry kCohesionGridPadding nodes past the lattice for the last row's lanes.
  if (nodes + static_cast<int64_t>(kCohesionGridPadding) > static_cast<int64_t>(g.scalar.size()))
    return -1;

  switch (cells) {  // validated to [2, 16], and 3 or 4 with "auto"
    case 2:
      return evaluateOnLattice<2>(model, cfg, L, nodes, lattice.node_sums, state, threads);
    case 3:
      return evaluateOnLattice<3>(model, cfg, L, nodes, lattice.node_sums, state, threads);
    case 4:
      return evaluateOnLattice<4>(model, cfg, L, nodes, lattice.node_sums, state, threads);
    case 5:
      return evaluateOnLattice<5>(model, cfg, L, nodes, lattice.node_sums, state, threads);
    case 6:
      return evaluateOnLattice<6>(model, cfg, L, nodes, lattice.node_sums, state, threads);
    case 7:
      return evaluateOnLattice<7>(model, cfg, L, nodes, lattice.node_sums, state, threads);
    case 8:
      return evaluateOnLattice<8>(model, cfg, L, nodes, lattice.node_sums, state, threads);
    case 9:
      return evaluateOnLattice<9>(model, cfg, L, nodes, lattice.node_sums, state, threads);
    case 10:
      return evaluateOnLattice<10>(model, cfg, L, nodes, lattice.node_sums, state, threads);
    case 11:
      return evaluateOnLattice<11>(model, cfg, L, nodes, lattice.node_sums, state, threads);
    case 12:
      return evaluateOnLattice<12>(model, cfg, L, nodes, lattice.node_sums, state, threads);
    case 13:
      return evaluateOnLattice<13>(model, cfg, L, nodes, lattice.node_sums, state, threads);
    case 14:
      return evaluateOnLattice<14>(model, cfg, L, nodes, lattice.node_sums, state, threads);
    case 15:
      return evaluateOnLattice<15>(model, cfg, L, nodes, lattice.node_sums, state, threads);
    case 16:
      return evaluateOnLattice<16>(model, cfg, L, nodes, lattice.node_sums, state, threads);
    default:
      return -1;
  }
}

}  // namespace wet_curly_hair

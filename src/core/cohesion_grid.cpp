#include "wet_curly_hair/core/cohesion_grid.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "wet_curly_hair/core/wet_kernels.h"

namespace wet_curly_hair {

namespace {

/// The part of the preallocated lattice used this step: origin (the hair's bounding box minus a
/// margin, so every quantity below depends on positions relative to the hair only), spacing and
/// dimensions; node (kx, ky, kz) sits at origin + spacing (kx, ky, kz).
struct Lattice {
  Vec3 origin;
  double c = 0.0, inv_c = 0.0;
  int64_t cells = 0;  ///< nodes per kernel radius: h = cells c
  int64_t nx = 0, ny = 0, nz = 0;
  double ka = 0.0, kb = 0.0;  ///< node kernel K(q) = q (q^2 + ka q + kb), q = h^2 - r^2 >= 0
  double kernel(double q) const { return q * (q * q + ka * q + kb); }
  int64_t index(int64_t kx, int64_t ky, int64_t kz) const { return (kz * ny + ky) * nx + kx; }
};

/// The lattice cell holding a point given relative to the origin: its lowest node and the
/// trilinear fractions.
struct Cell {
  int64_t kx, ky, kz;
  double tx, ty, tz;
};

inline Cell cellOf(const Lattice& L, const Vec3& r) {
  const double fx = r.x() * L.inv_c, fy = r.y() * L.inv_c, fz = r.z() * L.inv_c;
  Cell c;
  c.kx = static_cast<int64_t>(std::floor(fx));
  c.ky = static_cast<int64_t>(std::floor(fy));
  c.kz = static_cast<int64_t>(std::floor(fz));
  c.tx = fx - double(c.kx);
  c.ty = fy - double(c.ky);
  c.tz = fz - double(c.kz);
  return c;
}

/// Calls row(base, kx0, dy, dz, r2yz) for every lattice row (fixed ky, kz) that may hold nodes
/// within h = cells c of the point r (relative to the origin): the 2 cells nodes base + kx0 ..
/// base + kx0 + 2 cells - 1, which hold every node of the row within h (the others get q = 0),
/// node kx at offset (kx c - r.x, dy, dz) from the point, r2yz = dy^2 + dz^2. Fixed-width rows:
/// no per-row bounds, the loops vectorise. The lattice margin keeps every row inside it.
template <typename Row>
inline void forEachRowWithin(const Lattice& L, const Vec3& r, double h, Row row) {
  const double h2 = h * h;
  const int64_t cells = L.cells;
  const int64_t kx0 = static_cast<int64_t>(std::floor(r.x() * L.inv_c)) - cells + 1;
  const int64_t ky0 = static_cast<int64_t>(std::floor(r.y() * L.inv_c)) - cells + 1;
  const int64_t kz0 = static_cast<int64_t>(std::floor(r.z() * L.inv_c)) - cells + 1;
  for (int64_t kz = kz0; kz < kz0 + 2 * cells; ++kz) {
    const double dz = double(kz) * L.c - r.z();
    if (dz * dz >= h2) continue;
    for (int64_t ky = ky0; ky < ky0 + 2 * cells; ++ky) {
      const double dy = double(ky) * L.c - r.y();
      const double r2 = dy * dy + dz * dz;
      if (r2 >= h2) continue;
      row(L.index(0, ky, kz), kx0, dy, dz, r2);
    }
  }
}

/// sum_n W(|r - x_n|) a_n over the nodes within h (poly6 shape, unnormalised).
inline double gatherScalar(const Lattice& L, const double* __restrict a, const Vec3& r, double h) {
  const double h2 = h * h;
  double sum = 0.0;
  const int64_t width = 2 * L.cells;
  forEachRowWithin(L, r, h, [&](int64_t base, int64_t kx0, double, double, double r2yz) {
    const double* __restrict row = a + base;
    double part = 0.0;
    for (int64_t kx = kx0; kx < kx0 + width; ++kx) {
      const double dx = double(kx) * L.c - r.x();
      const double q = std::max(0.0, h2 - (dx * dx + r2yz));
      part += row[kx] * L.kernel(q);
    }
    sum += part;
  });
  return sum;
}

/// W~(r, p) = sum over the 8 nodes x_n of p's cell of t_n W(|r - x_n|): the functional the
/// lattice applies to one particle at p (both relative to the origin).
inline double interpolatedKernel(const Lattice& L, const Vec3& r, const Vec3& p, double h2) {
  const Cell c = cellOf(L, p);
  double sum = 0.0;
  for (int az = 0; az < 2; ++az) {
    const double wz = az ? c.tz : 1.0 - c.tz;
    const double dz = double(c.kz + az) * L.c - r.z();
    for (int ay = 0; ay < 2; ++ay) {
      const double wy = ay ? c.ty : 1.0 - c.ty;
      const double dy = double(c.ky + ay) * L.c - r.y();
      for (int ax = 0; ax < 2; ++ax) {
        const double wx = ax ? c.tx : 1.0 - c.tx;
        const double dx = double(c.kx + ax) * L.c - r.x();
        const double q = std::max(0.0, h2 - (dx * dx + dy * dy + dz * dz));
        sum += (wx * wy * wz) * L.kernel(q);
      }
    }
  }
  return sum;
}

/// Calls fn(node, t) for the 8 nodes of p's cell with their trilinear weights.
template <typename Fn>
inline void forEachCorner(const Lattice& L, const Vec3& p, Fn fn) {
  const Cell c = cellOf(L, p);
  for (int az = 0; az < 2; ++az)
    for (int ay = 0; ay < 2; ++ay)
      for (int ax = 0; ax < 2; ++ax)
        fn(L.index(c.kx + ax, c.ky + ay, c.kz + az), c.kx + ax, c.ky + ay, c.kz + az,
           (ax ? c.tx : 1.0 - c.tx) * (ay ? c.ty : 1.0 - c.ty) * (az ? c.tz : 1.0 - c.tz));
}

void zero(std::vector<double>* v, int64_t nodes, int threads) {
  double* a = v->data();
#pragma omp parallel for num_threads(threads) schedule(static)
  for (int64_t k = 0; k < nodes; ++k) a[k] = 0.0;
}

}  // namespace

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
  const double spacing = c.radius_m / c.grid_cells_per_radius;
  // The step's margin: (cells + 2) nodes below the box and (cells + 3) above it.
  const double per_axis = std::ceil(extent / spacing) + 2.0 * c.grid_cells_per_radius + 6.0;
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
  Lattice L;
  L.cells = cfg.grid_cells_per_radius;
  L.c = h / cfg.grid_cells_per_radius;
  L.inv_c = 1.0 / L.c;
  // Trilinear interpolation adds (c^2 / 2) t (1 - t) d2W/dx2 per axis, on average (c^2 / 12)
  // lap W: the nodes hold K = W - (c^2 / 12) lap W = q^3 + 3.5 c^2 q^2 - 2 c^2 h^2 q, whose
  // interpolant matches W to O(c^4) on average. Measured (README): RMS error 2.5x smaller at 4
  // nodes per radius, 1.7x at 3, but 1.03x larger at 2 (c = h / 2 is too coarse for the Taylor
  // argument), where it is left out.
  if (cfg.grid_cells_per_radius >= 3) {
    L.ka = 3.5 * L.c * L.c;
    L.kb = -2.0 * L.c * L.c * h2;
  }
  Vec3 lo = p[0], hi = p[0];
  for (int i = 1; i < n; ++i) {
    lo = lo.cwiseMin(p[i]);
    hi = hi.cwiseMax(p[i]);
  }
  // Kernel reach plus the trilinear cell on both sides (and one node of slack for round-off).
  const int64_t margin = cfg.grid_cells_per_radius + 2;
  L.origin = lo - Vec3::Constant(double(margin) * L.c);
  const Vec3 span = (hi - L.origin) * L.inv_c;
  if (!span.allFinite() || span.maxCoeff() > 1e6) return -1;
  L.nx = static_cast<int64_t>(std::floor(span.x())) + margin + 2;
  L.ny = static_cast<int64_t>(std::floor(span.y())) + margin + 2;
  L.nz = static_cast<int64_t>(std::floor(span.z())) + margin + 2;
  const int64_t nodes = L.nx * L.ny * L.nz;
  if (nodes > static_cast<int64_t>(g.scalar.size())) return -1;

  // Pass 1: mass to the nodes, density and volume of every particle.
  zero(&g.scalar, nodes, threads);
  for (int j = 0; j < n; ++j) {
    const double m = model.mass_kg[j];
    forEachCorner(L, p[j] - L.origin, [&](int64_t node, int64_t, int64_t, int64_t, double t) {
      g.scalar[node] += t * m;
    });
  }
  const double norm = 315.0 / (64.0 * M_PI * std::pow(h, 9));
#pragma omp parallel for num_threads(threads) schedule(dynamic, 256)
  for (int i = 0; i < n; ++i) {
    state->density[i] = norm * gatherScalar(L, g.scalar.data(), p[i] - L.origin, h);
    g.volume[i] = model.mass_kg[i] / state->density[i];
  }

  // Pass 2: V, V sigma and V sigma (p - x_n) to the nodes.
  for (std::vector<double>* v : {&g.scalar, &g.wet_volume, &g.qx, &g.qy, &g.qz})
    zero(v, nodes, threads);
  for (int j = 0; j < n; ++j) {
    const double v = g.volume[j], vs = v * state->saturation[j];
    const Vec3 r = p[j] - L.origin;
    forEachCorner(L, r, [&](int64_t node, int64_t kx, int64_t ky, int64_t kz, double t) {
      g.scalar[node] += t * v;
      if (vs == 0.0) return;
      const double tvs = t * vs;
      g.wet_volume[node] += tvs;
      g.qx[node] += tvs * (r.x() - double(kx) * L.c);
      g.qy[node] += tvs * (r.y() - double(ky) * L.c);
      g.qz[node] += tvs * (r.z() - double(kz) * L.c);
    });
  }

  const double* __restrict gv = g.scalar.data();
  const double* __restrict gs = g.wet_volume.data();
  const double* __restrict gx = g.qx.data();
  const double* __restrict gy = g.qy.data();
  const double* __restrict gz = g.qz.data();
  // Own-strand particles farther than this from p_i have no node within h.
  const double own_reach = h + std::sqrt(3.0) * L.c, own_reach2 = own_reach * own_reach;
  int clumped = 0;
#pragma omp parallel for num_threads(threads) schedule(dynamic, 256) reduction(+ : clumped)
  for (int i = 0; i < n; ++i) {
    if (state->saturation[i] <= 0.0) continue;  // dry particles keep p^w = p
    const Vec3 ri = p[i] - L.origin;
    // All strands: sum_n W_in V_n and sum_n W_in (Q_n + S_n (x_n - p_i)).
    double w_all = 0.0, px = 0.0, py = 0.0, pz = 0.0;
    forEachRowWithin(L, ri, h, [&](int64_t base, int64_t kx0, double dy, double dz, double r2yz) {
      double w_sum = 0.0, ax = 0.0, ay = 0.0, az = 0.0, s_sum = 0.0;
      for (int64_t kx = kx0; kx < kx0 + 2 * L.cells; ++kx) {
        const int64_t k = base + kx;
        const double dx = double(kx) * L.c - ri.x();
        const double q = std::max(0.0, h2 - (dx * dx + r2yz));
        const double w = L.kernel(q);
        const double ws = w * gs[k];
        w_sum += w * gv[k];
        s_sum += ws;
        ax += w * gx[k] + ws * dx;
        ay += w * gy[k];
        az += w * gz[k];
      }
      w_all += w_sum;
      px += ax;
      py += ay + s_sum * dy;
      pz += az + s_sum * dz;
    });
    // The own strand (particle i included) through the same functional, subtracted.
    const int s = static_cast<int>(state->grid.strand_of[i]);
    const int begin = model.strandBegin(s), end = begin + model.strandSize(s);
    double w_own = 0.0;
    Vec3 pull_own = Vec3::Zero();
    for (int j = begin; j < end; ++j) {
      const Vec3 d = p[j] - p[i];
      if (d.squaredNorm() >= own_reach2) continue;
      const double wt = interpolatedKernel(L, ri, p[j] - L.origin, h2);
      w_own += g.volume[j] * wt;
      pull_own += (g.volume[j] * state->saturation[j] * wt) * d;
    }
    double weight_sum = w_all - w_own;
    // Round-off of the cancellation: no other strand within reach.
    if (!(weight_sum > 1e-9 * w_own)) continue;
    const Vec3 pull = Vec3(px, py, pz) - pull_own;
    if (cfg.include_self) weight_sum += g.volume[i] * poly6Shape(0.0, h2);
    state->wet_position[i] = p[i] + (cfg.tightness / weight_sum) * pull;
    ++clumped;
  }
  return clumped;
}

}  // namespace wet_curly_hair

// The curl rotation M of eqs. (7)-(8) (A6-A8) and its time-constant filter (docs/physics.md
// §10.6) for a block of strands at once: per strand and substep it takes one acos, one sine and
// one cosine, which one strand at a time cost as much as the rest of the curl stage.
//
// glibc's vector math library (libmvec) has SIMD forms of the three; declared `simd`, as glibc's
// own math-vector.h declares them under -ffast-math, the loops below call them on 4 or 8 lanes
// at a time (within 4 ulp of the scalar forms). This file is compiled with -fno-math-errno
// (CMakeLists.txt), without which GCC keeps the scalar calls: the same results to round-off.
#include <algorithm>
#include <cmath>
#include <limits>

#include "solver_internal.h"
#include "wet_curly_hair/core/wet_kernels.h"

#if defined(__x86_64__) && defined(__GLIBC__)
extern "C" {
__attribute__((simd("notinbranch"))) double acos(double) noexcept;
__attribute__((simd("notinbranch"))) double sin(double) noexcept;
__attribute__((simd("notinbranch"))) double cos(double) noexcept;
}
#endif

namespace wet_curly_hair {
namespace detail {

namespace {

constexpr int kWidth = kCurlFilterWidth;

/// The filter's inputs and work, one array per component, one entry per strand of the block.
struct CurlFilterLanes {
  alignas(64) double hx[kWidth], hy[kWidth], hz[kWidth];  // helix root-to-tip unit axis
  alignas(64) double ax[kWidth], ay[kWidth], az[kWidth];  // hair root-to-tip, then its unit axis
  alignas(64) double min_len[kWidth];                     // A8: M is kept below this length
  alignas(64) double len[kWidth], cos_hp[kWidth];
  alignas(64) double qw[kWidth], qx[kWidth], qy[kWidth], qz[kWidth];  // M, then its update
  alignas(64) double tw[kWidth], tx[kWidth], ty[kWidth], tz[kWidth];  // M's target
  alignas(64) double cos_theta[kWidth], sign[kWidth], angle[kWidth], sin_a[kWidth], cos_a[kWidth];
};

/// The lanes' inputs; a lane without a strand to update gets a stand-in that A8 keeps.
void gatherLanes(const HairModel& model, const int* strand, const Vec3* root_to_tip,
                 const bool* update, int count, const HairState& state, CurlFilterLanes* w) {
  for (int l = 0; l < kWidth; ++l) {
    const bool on = l < count && update[l];
    const Vec3 h = on ? model.helix_axis[strand[l]] : Vec3::UnitZ();
    const Vec3 a = on ? root_to_tip[l] : Vec3::UnitZ();
    const Quat q = on ? state.curl_rotation[strand[l]] : Quat::Identity();
    w->hx[l] = h.x(), w->hy[l] = h.y(), w->hz[l] = h.z();
    w->ax[l] = a.x(), w->ay[l] = a.y(), w->az[l] = a.z();
    w->min_len[l] =
        on ? 1e-3 * model.strand_length_m[strand[l]] : std::numeric_limits<double>::infinity();
    w->qw[l] = q.w(), w->qx[l] = q.x(), w->qy[l] = q.y(), w->qz[l] = q.z();
  }
}

/// M's target on every lane, helixToHairQuaternion: (1 + c, h x p) normalised for the unit hair
/// axis p, c = h . p; lanes where h and p are nearly opposite then take its scalar half turn.
void targets(CurlFilterLanes* w) {
#pragma omp simd
  for (int l = 0; l < kWidth; ++l) {
    const double len = std::sqrt(w->ax[l] * w->ax[l] + w->ay[l] * w->ay[l] + w->az[l] * w->az[l]);
    const double inv_len = 1.0 / len;
    const double px = w->ax[l] * inv_len, py = w->ay[l] * inv_len, pz = w->az[l] * inv_len;
    double q[4];
    w->cos_hp[l] = helixToHairQuaternionRegular(w->hx[l], w->hy[l], w->hz[l], px, py, pz, q);
    w->tw[l] = q[0], w->tx[l] = q[1], w->ty[l] = q[2], w->tz[l] = q[3];
    w->ax[l] = px, w->ay[l] = py, w->az[l] = pz;
    w->len[l] = len;
  }
  for (int l = 0; l < kWidth; ++l) {
    if (!(w->cos_hp[l] < kOppositeCosine) || !(w->len[l] > w->min_len[l])) continue;
    const Quat t = helixToHairQuaternion(Vec3(w->hx[l], w->hy[l], w->hz[l]),
                                         Vec3(w->ax[l], w->ay[l], w->az[l]));
    w->tw[l] = t.w(), w->tx[l] = t.x(), w->ty[l] = t.y(), w->tz[l] = t.z();
  }
}

/// M <- slerp(M, target, f) along the shorter arc, normalised, as Eigen's slerp: with
/// cos theta = |M . target|, sin((1-f) theta) / sin theta = cos(f theta) - cos theta sin(f theta) /
/// sin theta and sin theta = sqrt(1 - cos^2 theta); a linear blend where theta is below round-off.
void slerpLanes(double f, CurlFilterLanes* w) {
#pragma omp simd
  for (int l = 0; l < kWidth; ++l) {
    const double d =
        w->qw[l] * w->tw[l] + w->qx[l] * w->tx[l] + w->qy[l] * w->ty[l] + w->qz[l] * w->tz[l];
    w->sign[l] = d < 0.0 ? -1.0 : 1.0;
    w->cos_theta[l] = std::min(std::abs(d), 1.0);
  }
  // One call per loop: GCC would fuse a sine and cosine into sincos, which has no simd form here.
#pragma omp simd
  for (int l = 0; l < kWidth; ++l) w->angle[l] = f * acos(w->cos_theta[l]);
#pragma omp simd
  for (int l = 0; l < kWidth; ++l) w->sin_a[l] = sin(w->angle[l]);
#pragma omp simd
  for (int l = 0; l < kWidth; ++l) w->cos_a[l] = cos(w->angle[l]);
  constexpr double kLinear = 1.0 - std::numeric_limits<double>::epsilon();
#pragma omp simd
  for (int l = 0; l < kWidth; ++l) {
    const double ct = w->cos_theta[l];
    const bool linear = ct >= kLinear;
    const double sin_theta = std::sqrt((1.0 - ct) * (1.0 + ct));
    const double b = linear ? f : w->sin_a[l] / sin_theta;
    const double a = linear ? 1.0 - f : w->cos_a[l] - ct * b;
    const double bs = w->sign[l] * b;
    const double qw = a * w->qw[l] + bs * w->tw[l], qx = a * w->qx[l] + bs * w->tx[l];
    const double qy = a * w->qy[l] + bs * w->ty[l], qz = a * w->qz[l] + bs * w->tz[l];
    const double inv_norm = 1.0 / std::sqrt(qw * qw + qx * qx + qy * qy + qz * qz);
    w->qw[l] = qw * inv_norm, w->qx[l] = qx * inv_norm;
    w->qy[l] = qy * inv_norm, w->qz[l] = qz * inv_norm;
  }
}

}  // namespace

void updateCurlRotations(const HairModel& model, const int* strand, const Vec3* root_to_tip,
                         const bool* update, int count, double follow_fraction, HairState* state) {
  CurlFilterLanes w;
  gatherLanes(model, strand, root_to_tip, update, count, *state, &w);
  targets(&w);
  if (follow_fraction >= 1.0) {
    for (int l = 0; l < kWidth; ++l)
      w.qw[l] = w.tw[l], w.qx[l] = w.tx[l], w.qy[l] = w.ty[l], w.qz[l] = w.tz[l];
  } else {
    slerpLanes(follow_fraction, &w);
  }
  for (int l = 0; l < count; ++l) {
    // A8: a strand curled back onto its root has no axis; it keeps the last M.
    if (!update[l] || !(w.len[l] > w.min_len[l])) continue;
    state->curl_rotation[strand[l]] = Quat(w.qw[l], w.qx[l], w.qy[l], w.qz[l]);
  }
}

}  // namespace detail
}  // namespace wet_curly_hair

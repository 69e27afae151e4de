// Hair-hair contact (Iben et al. 2013 §2.8 of docs/physics.md, A21): penalty springs between
// collision spheres on a pruned subset of the particles, stiffness ramped in on first contact and
// tapered out on release, Coulomb friction between strands. The forces couple strands, so they
// are evaluated once per substep for every strand and added to the strand steps as an external
// force; with an implicit integrator each sphere's own normal stiffness and damping also enter
// its strand's implicit solve, the other strand held where it was at the substep's start (the
// documented split of docs/hair_contact.md).
#pragma once

#include <cstdint>

#include "wet_curly_hair/core/config.h"
#include "wet_curly_hair/core/model.h"
#include "wet_curly_hair/core/state.h"
#include "wet_curly_hair/core/types.h"

namespace wet_curly_hair {

/// One sphere pair's law. `force` is the force on sphere i for the explicit method: the normal
/// push and kinetic friction capped at what stops the sliding within the substep. While the pair
/// pushes, also its linearisation for an implicit step: `push` the normal force's size,
/// `stiffness` k and `damping` c (-d f_i / d x_i = k n n^T and -d f_i / d v_i = c n n^T along the
/// normal; the turning of n is left out), and `friction_damping` c_t, kinetic friction written
/// as viscous drag c_t P (v_j - v_i), P = I - n n^T, with c_t = mu push / |dv_t| (capped at
/// 100 m_eff / h, past which the sliding stops within the substep anyway).
struct HairContactPair {
  Vec3 force = Vec3::Zero();
  Vec3 normal = Vec3::Zero();     ///< n = d / |d|, from i toward j.
  double push = 0.0;              ///< N, >= 0.
  double stiffness = 0.0;         ///< N/m while the pair pushes, else 0.
  double damping = 0.0;           ///< N s/m while the pair pushes, else 0.
  double friction_damping = 0.0;  ///< N s/m while the pair pushes and slides, else 0.
};

/// The pair force on sphere i from sphere j (f on j is its negative, to the last bit: every term
/// flips sign exactly when i and j swap). d = x_j - x_i; dv = v_j - v_i; contact distance 2 r;
/// k, c the pair's stiffness and damping (already scaled by the ramp), m_eff the reduced mass,
/// h the substep. Zero when the spheres do not touch. Normal part: -(k (2r - |d|) +
/// c (dv . n)) n with n = d / |d|, clamped so it never pulls (a separating pair is not held);
/// tangential part: Coulomb, -min(mu |f_n|, m_eff |dv_t| / h) dv_t / |dv_t|.
HairContactPair hairContactPair(const Vec3& d, const Vec3& dv, double contact_m, double k, double c,
                                double friction, double m_eff, double h);

/// hairContactPair's force alone.
inline Vec3 hairContactPairForce(const Vec3& d, const Vec3& dv, double contact_m, double k,
                                 double c, double friction, double m_eff, double h) {
  return hairContactPair(d, dv, contact_m, k, c, friction, m_eff, h).force;
}

/// The penalty's potential energy of one sphere pair, 1/2 k (2r - |d|)^2 while they touch (the
/// push of hairContactPair is its negative gradient when c = 0 and mu = 0), J.
inline double hairContactPairEnergy(const Vec3& d, double contact_m, double k) {
  const double r = d.norm();
  return r < contact_m ? 0.5 * k * (contact_m - r) * (contact_m - r) : 0.0;
}

/// The contact's potential energy in the state: the sum of hairContactPairEnergy over the
/// touching sphere pairs of different strands, each with its engaged stiffness
/// min(a_i, a_j) K l_i l_j, J. Prunes the spheres first when needed; uses the contact's grid as
/// scratch (the pair list is kept).
double hairContactEnergy(const HairModel& model, const HairContactConfig& config, HairState* state);

/// One step of the ramp variable a of a sphere (docs/hair_contact.md): toward 1 at h / ramp
/// while touching, toward 0 at h / taper otherwise. A pair's stiffness is min(a_i, a_j) K l_i l_j.
double hairContactEngagement(double a, bool touching, double h, double ramp_s, double taper_s);

/// Prunes the spheres (when the model's particle count, radius or sparsity changed since the
/// last call) and resets the engagements. No-op when nothing changed.
void prepareHairContact(const HairModel& model, const HairContactConfig& config,
                        HairContactState* contact);

/// One substep's contact forces, added to state->external_force (which the caller zeroes), and
/// per strand whether any force was applied (contact->strand_touching). With `implicit_theta`
/// > 0 (the theta of an implicit integrator; 0: explicit) each sphere particle's pairs also give
/// the block (theta h^2 k + h c) n n^T of its strand's implicit solve
/// (HairContactState::external_block): the contact as backward Euler in the sphere's own position
/// and velocity, the other strand held (the velocity it damps is folded into the force as
/// c n n^T v_i / theta). Rebuilds the Verlet list
/// when a sphere has moved more than half the skin in the head frame (`head`: head -> world at
/// the substep's start); the result does not depend on the thread count. Returns the touching
/// pairs.
uint64_t computeHairContactForces(const HairModel& model, const HairContactConfig& config, double h,
                                  double implicit_theta, const Pose& head, int threads,
                                  HairState* state);

}  // namespace wet_curly_hair

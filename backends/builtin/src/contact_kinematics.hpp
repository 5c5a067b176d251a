// Private to the built-in DEM: the geometry and relative motion of one contact, shared by the pair
// and the wall loops, and the one switch that turns the study's contact model into the template
// arguments of those loops.
//
// Contract
// - contactKinematics<Wall>: n is the unit normal towards particle i, r the centre distance (pair) or
//   the centre-to-wall distance (wall), ri and rj the radii (rj unused for a wall). vi, wi are i's
//   velocity and spin; vj, wj body j's (a wall: its velocity at the contact point; wj unused, no
//   spin). Fills every field of ContactKinematics: overlap delta (> 0 when touching), R* (a wall:
//   R_i), centre-to-contact distances (pair: R - delta/2 each; wall: r and 0), normal relative
//   velocity vn = (v_i - v_j) . n and the tangential velocity of the contact point including the
//   spins, vt = v_r - vn n - (d_i w_i + d_j w_j) x n.
// - withModel calls f.template operator()<N, R, Shear>() once, with the study's normal and rolling
//   models and whether it keeps a tangential history.
#pragma once

#include "demfem/backends/builtin/contact_law.hpp"
#include "demfem/study/study.hpp"

namespace demfem::builtin {

// Overlap and R* of a particle pair at centre distance r (radii ri, rj).
struct PairOverlap {
  double delta, reff;
};
[[gnu::always_inline]] inline PairOverlap pairOverlap(double r, double ri, double rj) {
  const double rs = ri + rj;
  return {rs - r, ri * rj / rs};
}

template <bool Wall>
[[gnu::always_inline]] inline ContactKinematics contactKinematics(const double* n, double r, double ri, double rj,
                                                                  const double* vi, const double* wi, const double* vj,
                                                                  const double* wj) {
  ContactKinematics k;
  for (int c = 0; c < 3; ++c) k.n[c] = n[c];
  k.r = r;
  k.ri = ri;
  if constexpr (Wall) {
    k.delta = ri - r;
    k.rj = 0;
    k.reff = ri;
    k.di = r;
    k.dj = 0;
  } else {
    const PairOverlap o = pairOverlap(r, ri, rj);
    k.delta = o.delta;
    k.rj = rj;
    k.reff = o.reff;
    k.di = ri - 0.5 * k.delta;
    k.dj = rj - 0.5 * k.delta;
  }
  double vr[3], wr[3];
  for (int c = 0; c < 3; ++c) {
    vr[c] = vi[c] - vj[c];
    k.wi[c] = wi[c];
    if constexpr (Wall) {
      k.wj[c] = 0;
      k.wrel[c] = k.wi[c];
      wr[c] = k.di * k.wi[c];
    } else {
      k.wj[c] = wj[c];
      k.wrel[c] = k.wi[c] - k.wj[c];
      wr[c] = k.di * k.wi[c] + k.dj * k.wj[c];
    }
  }
  k.vn = detail::dot3(vr, k.n);
  double wxn[3];
  detail::cross3(wr, k.n, wxn);
  for (int c = 0; c < 3; ++c) k.vt[c] = vr[c] - k.vn * k.n[c] - wxn[c];
  return k;
}

template <class F>
void withModel(const study::ContactModel& model, F&& f) {
  using NM = study::NormalModel;
  using RM = study::RollingModel;
  const auto shear = [&]<NM N, RM R>() {
    if (model.tangential_history) f.template operator()<N, R, true>();
    else f.template operator()<N, R, false>();
  };
  const auto rolling = [&]<NM N>() {
    switch (model.rolling) {
      case RM::None: shear.template operator()<N, RM::None>(); break;
      case RM::EdemStandard: shear.template operator()<N, RM::EdemStandard>(); break;
      case RM::Cdt: shear.template operator()<N, RM::Cdt>(); break;
      case RM::Epsd: shear.template operator()<N, RM::Epsd>(); break;
    }
  };
  switch (model.normal) {
    case NM::EdemHysteretic: rolling.template operator()<NM::EdemHysteretic>(); break;
    case NM::Hooke: rolling.template operator()<NM::Hooke>(); break;
    case NM::HookeHysteresis: rolling.template operator()<NM::HookeHysteresis>(); break;
  }
}

}  // namespace demfem::builtin

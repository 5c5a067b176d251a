// Contact laws of the built-in DEM (docs/architecture.md section 11): the force and torque of one
// sphere-sphere or sphere-wall contact, for the EDEM-style and the LIGGGHTS 3.8-compatible models.
//
// Contract
// - SI units. Contact normal n points from the wall / particle j towards particle i; delta > 0 is
//   the overlap; vn = (v_i - v_j) . n (negative while approaching). A wall contact uses R* = R_i and
//   m* = m_i (LIGGGHTS convention, also EDEM's for a flat wall).
// - Normal force Fn along +n (repulsive > 0) = elastic/plastic part + viscous part + cohesion (< 0).
// - The functions are inline and allocation-free; the caller chooses the model outside the loop by
//   templates (contactForce<Normal, Rolling>), the cohesion model by a switch that never changes.
// - History per contact (reset to zero when the contact opens, delta <= 0): the tangential spring
//   displacement (3), the maximum overlap (1, hysteretic models), the elastic rolling torque (3, epsd).
//
// Formulas and sources
// - EDEM hysteretic spring (Walton & Braun 1986, as EDEM documents it): loading stiffness
//   K1 = 5 R* min(Y_i, Y_j) (a yield strength of 0 means "not limiting": walls use the particle's), unloading K2 = K1 / e^2, Fn = max(0, min(K1 delta, K2 (delta - delta0))),
//   delta0 = delta_max (1 - K1/K2). Documented assumptions for Table 2's factors: the "damping
//   factor" D_n adds a viscous force c vn with c = 2 D_n sqrt(m* k) of the branch in use (K1 while
//   loading, K2 while un/reloading; none in the plastic gap delta <= delta0; the total is clamped at
//   0) and c_t = 2 D_n sqrt(m* k_t) on the tangential spring; the "stiffness factor" gives
//   k_t = stiffness_factor * K1. With D_n = 0 the restitution is e exactly (hysteresis alone);
//   without any normal damping a settled packing keeps vibrating on the elastic K2 branch.
// - EDEM linear cohesion: Fn_coh = -k_coh A. Documented assumption (the vendor's V2 model uses a
//   smaller area than V1): A = pi R* delta, the Hertzian contact area, half the geometric overlap
//   circle used by V1 and by LIGGGHTS sjkr.
// - EDEM standard rolling friction: torque on i = -mu_r Fn d_i w_hat_i, d_i the centre-to-contact
//   distance, w_hat_i the particle's own unit angular velocity, Fn the normal contact force
//   (elastic + viscous, without cohesion, clamped at 0).
// - LIGGGHTS hooke (normal_model_hooke.h, 3.8): kn = 16/15 sqrt(R*) Y* (15 m* v_c^2 /
//   (16 sqrt(R*) Y*))^(1/5), Y* = 1 / ((1 - nu_i^2)/Y_i + (1 - nu_j^2)/Y_j), kt = kn,
//   gamma_n = gamma_t = sqrt(4 m* kn / (1 + (pi / ln e)^2)), Fn = kn delta - gamma_n vn.
// - LIGGGHTS hooke/hysteresis (Luding; normal_model_hooke_hysteresis.h): k2 grows linearly with
//   delta_max from kn to k2max = kn * coefficientMaxElasticStiffness, reached at
//   delta_lim = k2max / (k2max - kn) * coefficientPlasticityDepth * 2 R*; loading along kn delta,
//   un/reloading along k2 (delta - delta_max) + kn delta_max, adhesive branch floored at -kc delta
//   (kc = kn * coefficientAdhesionStiffness, delta_max then moved as LIGGGHTS does); plus -gamma_n vn.
// - LIGGGHTS tangential history (tangential_model_history.h): shear += v_t dt, rotated into the
//   tangent plane, Ft = -kt shear, capped at mu |Fn| (shear rescaled), otherwise Ft -= gamma_t v_t.
//   |Fn| is the total normal force (incl. damping and cohesion), as LIGGGHTS computes it.
// - LIGGGHTS sjkr: A = the overlap circle area, pi/4 * -(r-ri-rj)(r+ri-rj)(r-ri+rj)(r+ri+rj)/r^2,
//   against a wall pi (R^2 - d^2); sjkr2: A = 4 pi R* delta, against a wall 2 pi R delta.
// - LIGGGHTS cdt: torque = mu_r (kn delta) R* w_hat_rel (wall: R* -> d_i), torsion part removed,
//   subtracted from i and added to j.
// - LIGGGHTS epsd: spring torque += kr w_rel,t dt with kr = 2.25 kn mu_r^2 R*^2, capped at
//   mu_r R* |Fn|. The study file has no rolling viscous damping, so epsd's dashpot coefficient is 0
//   (LIGGGHTS coefficientRollingViscousDamping = 0).
#pragma once

#include "demfem/backends/physics/dem_formulas.hpp"
#include "demfem/study/study.hpp"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <numbers>

namespace demfem::builtin {

// Coefficients of one material pair, resolved once from the study (interaction table + materials).
struct PairLaw {
  bool defined = false;       // the study has an interaction for this pair
  double restitution = 0.5;
  double friction = 0.5;
  double rolling_friction = 0;
  double cohesion_J_m3 = 0;
  double yield_min_Pa = 0;    // min(Y_i, Y_j): EDEM K1 = 5 R* Y
  double youngs_eff_Pa = 0;   // Y* of LIGGGHTS hooke
  double log_restitution = 0; // ln e
};

// Per-contact stiffness and damping, fixed for a given pair of bodies (computed once per
// neighbour-list slot or wall contact).
struct ContactStiffness {
  double kn = 0;       // loading stiffness (N/m): EDEM K1, LIGGGHTS kn
  double kt = 0;       // tangential spring (N/m)
  double gamma_n = 0;  // normal viscous coefficient (N s/m)
  double gamma_t = 0;  // tangential viscous coefficient (N s/m)
};

inline ContactStiffness contactStiffness(const study::ContactModel& model, const PairLaw& law,
                                         double reff, double meff) {
  ContactStiffness s;
  switch (model.normal) {  // no default: a new normal law must say its stiffness here
    case study::NormalModel::EdemHysteretic:
      s.kn = physics::edemLoadingStiffness(reff, law.yield_min_Pa);
      s.kt = model.stiffness_factor * s.kn;
      s.gamma_n = 2.0 * model.damping_factor * std::sqrt(meff * s.kn);  // on the K1 branch
      s.gamma_t = 2.0 * model.damping_factor * std::sqrt(meff * s.kt);
      return s;
    case study::NormalModel::Hooke:
    case study::NormalModel::HookeHysteresis: {
      s.kn = physics::hookeNormalStiffness(law.youngs_eff_Pa, reff, meff, model.characteristic_velocity_m_s);
      s.kt = s.kn;
      const double q = std::numbers::pi / law.log_restitution;
      s.gamma_n = std::sqrt(4.0 * meff * s.kn / (1.0 + q * q));
      s.gamma_t = s.gamma_n;
      return s;
    }
  }
  return s;
}

// Largest spring stiffness a contact with this stiffness can reach (the stability check of
// DemSimulation::setTimeStep; the study's step itself comes from physics/time_step.hpp).
inline double stiffestSpring(const study::ContactModel& model, const PairLaw& law, const ContactStiffness& s) {
  switch (model.normal) {
    case study::NormalModel::EdemHysteretic: return physics::edemUnloadingStiffness(s.kn, law.restitution);
    case study::NormalModel::HookeHysteresis: return physics::hookeHysteresisPeakStiffness(s.kn, model.coefficient_max_elastic_stiffness);
    case study::NormalModel::Hooke: break;
  }
  return s.kn;
}

// History slots of one contact as stored (HistoryLayout::size doubles per contact); offsets are -1
// when the model does not use them.
struct HistoryLayout {
  int size = 0;
  int shear = -1;      // 3 doubles
  int delta_max = -1;  // 1 double
  int roll = -1;       // 3 doubles
  static constexpr int kMaxSize = 7;
  static constexpr HistoryLayout of(study::NormalModel normal, study::RollingModel rolling, bool tangential_history) {
    HistoryLayout h;
    if (tangential_history) { h.shear = h.size; h.size += 3; }
    if (normal != study::NormalModel::Hooke) { h.delta_max = h.size; h.size += 1; }
    if (rolling == study::RollingModel::Epsd) { h.roll = h.size; h.size += 3; }
    return h;
  }
  static HistoryLayout of(const study::ContactModel& m) { return of(m.normal, m.rolling, m.tangential_history); }
};

// The history of one contact as the law reads and updates it (the fields its layout lacks stay 0).
struct ContactHistory {
  double shear[3] = {0, 0, 0};
  double delta_max = 0;
  double roll[3] = {0, 0, 0};
};

[[gnu::always_inline]] inline ContactHistory loadHistory(const HistoryLayout& h, const double* stored) {
  ContactHistory out;
  if (h.shear >= 0)
    for (int c = 0; c < 3; ++c) out.shear[c] = stored[h.shear + c];
  if (h.delta_max >= 0) out.delta_max = stored[h.delta_max];
  if (h.roll >= 0)
    for (int c = 0; c < 3; ++c) out.roll[c] = stored[h.roll + c];
  return out;
}

[[gnu::always_inline]] inline void storeHistory(const HistoryLayout& h, const ContactHistory& in, double* stored) {
  if (h.shear >= 0)
    for (int c = 0; c < 3; ++c) stored[h.shear + c] = in.shear[c];
  if (h.delta_max >= 0) stored[h.delta_max] = in.delta_max;
  if (h.roll >= 0)
    for (int c = 0; c < 3; ++c) stored[h.roll + c] = in.roll[c];
}

// The same for contact k of a batch that holds its histories by stored offset (hist[offset][k]),
// with the layout L fixed at compile time: a batch loop then reads and writes contiguous arrays.
template <HistoryLayout L>
[[gnu::always_inline]] inline ContactHistory loadBatchHistory(const double* const* hist, std::size_t k) {
  ContactHistory out;
  if constexpr (L.shear >= 0)
    for (int c = 0; c < 3; ++c) out.shear[c] = hist[L.shear + c][k];
  if constexpr (L.delta_max >= 0) out.delta_max = hist[L.delta_max][k];
  if constexpr (L.roll >= 0)
    for (int c = 0; c < 3; ++c) out.roll[c] = hist[L.roll + c][k];
  return out;
}

template <HistoryLayout L>
[[gnu::always_inline]] inline void storeBatchHistory(const ContactHistory& in, double* const* hist, std::size_t k) {
  if constexpr (L.shear >= 0)
    for (int c = 0; c < 3; ++c) hist[L.shear + c][k] = in.shear[c];
  if constexpr (L.delta_max >= 0) hist[L.delta_max][k] = in.delta_max;
  if constexpr (L.roll >= 0)
    for (int c = 0; c < 3; ++c) hist[L.roll + c][k] = in.roll[c];
}

// Geometry and kinematics of one contact, filled by the caller.
struct ContactKinematics {
  double n[3];        // unit normal, towards i
  double delta;       // overlap > 0
  double vn;          // normal relative velocity (v_i - v_j) . n
  double vt[3];       // tangential relative velocity at the contact point (incl. rotation)
  double wrel[3];     // w_i - w_j (wall: w_i)
  double wrel_norm;   // |wrel| (needed by cdt only; the pair loop computes it for a batch of contacts)
  double wi[3], wj[3];// angular velocities (wall: wj = 0)
  double reff;        // R* (wall: R_i)
  double di, dj;      // centre-to-contact distances (wall: dj = 0)
  double ri;          // radius of i (wall cohesion areas)
  double r;           // centre distance (pair) or centre-wall distance (wall)
  double rj;          // radius of j (pair), 0 for a wall
  double inv_ii = 0, inv_ij = 0;  // 1 / moment of inertia of i and j (wall: 0 for j); edem-standard only
};

struct ContactResult {
  double force[3];    // on i (j gets the opposite)
  double torque_i[3];
  double torque_j[3];
  double normal_force;// Fn along n incl. cohesion (for reporting)
};

namespace detail {
inline double dot3(const double* a, const double* b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
inline double norm2(const double* a) { return dot3(a, a); }
inline void cross3(const double* a, const double* b, double* c) {
  c[0] = a[1] * b[2] - a[2] * b[1];
  c[1] = a[2] * b[0] - a[0] * b[2];
  c[2] = a[0] * b[1] - a[1] * b[0];
}
}  // namespace detail

// The branches of the laws below are written as selects, so that a loop over a batch of contacts
// vectorises (builtin/src/pair_forces.cpp); each value is that of the branch taken, bit for bit.

// Normal force (elastic/plastic + viscous, no cohesion) of normal model N; updates delta_max.
template <study::NormalModel N>
[[gnu::always_inline]] inline double normalForce(const study::ContactModel& model, const PairLaw& law, const ContactStiffness& s,
                                                 const ContactKinematics& k, double& delta_max) {
  const double delta = k.delta;
  if constexpr (N == study::NormalModel::Hooke) {
    return s.kn * delta - s.gamma_n * k.vn;
  } else if constexpr (N == study::NormalModel::EdemHysteretic) {
    // Walton-Braun: loading K1, unloading/reloading K2 = K1/e^2 from delta0 = delta_max (1 - e^2).
    delta_max = std::max(delta_max, delta);
    const double e = law.restitution;
    const double loading = s.kn * delta;
    const double unloading = s.kn / (e * e) * (delta - delta_max * (1.0 - e * e));
    const double on_loading = std::max(0.0, loading - s.gamma_n * k.vn);
    const double on_unloading = std::max(0.0, unloading - s.gamma_n / e * k.vn);  // sqrt(K2/K1) = 1/e
    const double unloading_or_gap = unloading <= 0 ? 0.0 : on_unloading;  // 0: the plastic gap
    return loading <= unloading ? on_loading : unloading_or_gap;
  } else {
    // LIGGGHTS hooke/hysteresis (Luding's elasto-plastic adhesive spring).
    const double kn = s.kn;
    const double k2max = kn * model.coefficient_max_elastic_stiffness;
    const double kc = kn * model.coefficient_adhesion_stiffness;
    const double dmax = std::max(delta_max, delta);
    const double lim = k2max / (k2max - kn) * model.coefficient_plasticity_depth * 2.0 * k.reff;
    const double beyond_trial = k2max * (delta - lim) + kn * lim;  // delta_max past the limit
    const double k2 = kn + (k2max - kn) * dmax / lim;
    const double trial = k2 * (delta - dmax) + kn * dmax;
    const bool beyond = dmax >= lim;
    const bool loading = !beyond && trial >= kn * delta;
    const bool adhesive = beyond ? !(beyond_trial >= -kc * delta) : !loading && !(trial > -kc * delta);
    // On the adhesive branch delta_max moves as LIGGGHTS moves it.
    const double adhesive_dmax = 0.5 * (delta + std::sqrt(delta * delta + 4.0 * ((kn + kc) * delta * lim / (k2max - kn))));
    const double f = adhesive ? -kc * delta : beyond ? beyond_trial : loading ? kn * delta : trial;
    delta_max = adhesive ? adhesive_dmax : dmax;
    return f - s.gamma_n * k.vn;
  }
}

// Cohesive normal force (<= 0) of cohesion model C, from the contact's geometry: cohesion energy
// density (J/m3), R*, overlap, radius of i, centre distance (pair) or centre-wall distance (wall),
// radius of j (pair).
template <study::CohesionModel C>
[[gnu::always_inline]] inline double cohesionForce(double cohesion_J_m3, double reff, double delta, double ri, double r,
                                                   double rj, bool wall) {
  constexpr double pi = std::numbers::pi;
  double area = 0;
  if constexpr (C == study::CohesionModel::None) {
    return 0;
  } else if constexpr (C == study::CohesionModel::EdemLinear) {
    area = pi * reff * delta;
  } else if constexpr (C == study::CohesionModel::Sjkr) {
    area = wall ? pi * (ri * ri - r * r)
                : -pi / 4.0 * ((r - ri - rj) * (r + ri - rj) * (r - ri + rj) * (r + ri + rj)) / (r * r);
  } else {
    area = wall ? 2.0 * pi * ri * delta : 4.0 * pi * reff * delta;
  }
  return -cohesion_J_m3 * area;
}

// withCohesion calls f.template operator()<C>() once, with the study's cohesion model.
template <class F>
void withCohesion(study::CohesionModel model, F&& f) {
  using CM = study::CohesionModel;
  switch (model) {
    case CM::None: f.template operator()<CM::None>(); break;
    case CM::EdemLinear: f.template operator()<CM::EdemLinear>(); break;
    case CM::Sjkr: f.template operator()<CM::Sjkr>(); break;
    case CM::Sjkr2: f.template operator()<CM::Sjkr2>(); break;
  }
}

inline double cohesionForce(study::CohesionModel model, const PairLaw& law, const ContactKinematics& k, bool wall) {
  double f = 0;
  withCohesion(model, [&]<study::CohesionModel C>() { f = cohesionForce<C>(law.cohesion_J_m3, k.reff, k.delta, k.ri, k.r, k.rj, wall); });
  return f;
}

// Spin below which the edem-standard torque M = -mu_r Fn d w_hat falls linearly to zero: the spin
// that M removes in one step `dt_r`, times kRollingStopContacts. A constant torque that reverses a
// spin within a step feeds energy in: the spin chatters at about M dt / I and a pack never comes to
// rest (docs/builtin-dem.md, "Rolling friction at rest"). Below this scale the torque is
// -I w / (kRollingStopContacts dt_r) per contact, so that a particle with that many contacts only
// stops, never reverses, in one step dt <= dt_r. dt_r is the longer of the DEM step and the
// regularisation step (physics::rollingRegularisationStep): below that step the law is the same at
// every step. 0 when inv_inertia is 0 (the law as EDEM states it).
inline constexpr double kRollingStopContacts = 12;  // the densest coordination of equal spheres
inline double rollingSpinScale(double torque, double inv_inertia, double dt_r) {
  return kRollingStopContacts * torque * dt_r * inv_inertia;
}

// The complete contact: normal, tangential (Shear: with the history spring) and rolling, plus the
// cohesive normal force `cohesion` (<= 0, cohesionForce). `h` is the contact's history, updated;
// `dt` is the DEM step, `rolling_dt` (>= dt) the step of the rolling law's spin scale
// (rollingSpinScale).
template <study::NormalModel N, study::RollingModel R, bool Shear>
[[gnu::always_inline]] inline ContactResult contactForce(const study::ContactModel& model, const PairLaw& law,
                                                         const ContactStiffness& s, const ContactKinematics& k, double dt,
                                                         double rolling_dt, double cohesion, ContactHistory& h, bool wall) {
  using detail::cross3;
  using detail::dot3;
  ContactResult out{};
  const double fn_contact = normalForce<N>(model, law, s, k, h.delta_max);
  const double fn = fn_contact + cohesion;
  out.normal_force = fn;

  // Tangential force (Coulomb friction with a tangential spring).
  double ft[3];
  const double limit = law.friction * std::fabs(fn);
  if constexpr (Shear) {
    double sh[3];
    for (int c = 0; c < 3; ++c) sh[c] = h.shear[c] + k.vt[c] * dt;
    const double rsht = dot3(sh, k.n);
    for (int c = 0; c < 3; ++c) sh[c] -= rsht * k.n[c];
    for (int c = 0; c < 3; ++c) ft[c] = -s.kt * sh[c];
    const double shear_force2 = s.kt * s.kt * dot3(sh, sh);
    const bool slips = shear_force2 > limit * limit;  // squares: the square root only scales a slip
    const double ratio = limit / std::sqrt(shear_force2);
    for (int c = 0; c < 3; ++c) {
      const double slipping = ft[c] * ratio;
      h.shear[c] = slips ? -slipping / s.kt : sh[c];
      ft[c] = slips ? slipping : ft[c] - s.gamma_t * k.vt[c];
    }
  } else {
    const double vtm = std::sqrt(dot3(k.vt, k.vt));
    const double mag = std::min(limit, s.gamma_t * vtm);
    for (int c = 0; c < 3; ++c) ft[c] = vtm > 0 ? -mag * k.vt[c] / vtm : 0.0;
  }
  for (int c = 0; c < 3; ++c) out.force[c] = fn * k.n[c] + ft[c];
  double nxft[3];
  cross3(k.n, ft, nxft);
  for (int c = 0; c < 3; ++c) {
    out.torque_i[c] = -k.di * nxft[c];
    out.torque_j[c] = -k.dj * nxft[c];
  }

  // Rolling resistance (a torque that is not applied leaves the sum as it was, signed zeros too).
  if constexpr (R == study::RollingModel::EdemStandard) {
    const double f = law.rolling_friction * std::max(0.0, fn_contact);
    const double wim = std::max(std::sqrt(dot3(k.wi, k.wi)), rollingSpinScale(f * k.di, k.inv_ii, rolling_dt));
    const double wjm = std::max(std::sqrt(dot3(k.wj, k.wj)), rollingSpinScale(f * k.dj, k.inv_ij, rolling_dt));
    for (int c = 0; c < 3; ++c) {
      const double ti = out.torque_i[c] - f * k.di * k.wi[c] / wim;
      const double tj = out.torque_j[c] - f * k.dj * k.wj[c] / wjm;
      out.torque_i[c] = wim > 0 ? ti : out.torque_i[c];
      out.torque_j[c] = wjm > 0 ? tj : out.torque_j[c];
    }
  } else if constexpr (R == study::RollingModel::Cdt) {
    const double wm = k.wrel_norm;
    const double arm = wall ? k.di : k.reff;
    const double scale = law.rolling_friction * s.kn * k.delta * arm / wm;
    double tq[3];
    for (int c = 0; c < 3; ++c) tq[c] = scale * k.wrel[c];
    const double tn = dot3(tq, k.n);
    for (int c = 0; c < 3; ++c) {
      const double t = tq[c] - tn * k.n[c];
      out.torque_i[c] = wm > 0 ? out.torque_i[c] - t : out.torque_i[c];
      out.torque_j[c] = wm > 0 ? out.torque_j[c] + t : out.torque_j[c];
    }
  } else if constexpr (R == study::RollingModel::Epsd) {
    const double wn = dot3(k.wrel, k.n);
    const double kr = 2.25 * s.kn * law.rolling_friction * law.rolling_friction * k.reff * k.reff;
    double tq[3];
    for (int c = 0; c < 3; ++c) tq[c] = h.roll[c] + kr * (k.wrel[c] - wn * k.n[c]) * dt;
    const double mag = std::sqrt(dot3(tq, tq));
    const double cap = std::fabs(fn) * k.reff * law.rolling_friction;
    const double f = cap / mag;
    for (int c = 0; c < 3; ++c) {
      h.roll[c] = mag > cap ? tq[c] * f : tq[c];
      out.torque_i[c] -= h.roll[c];
      out.torque_j[c] += h.roll[c];
    }
  }
  return out;
}

}  // namespace demfem::builtin

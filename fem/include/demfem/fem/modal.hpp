// demfem time integration of the reduced tool model in modal coordinates: paper Eq (4)-(10) projected on
// the natural modes of the Rayleigh-damped model (docs/fem.md, section Modal integration).
//
// With Phi the M-normalized modes of (K, M) on the free DOFs (Phi^T M Phi = I, Phi^T K Phi = W^2),
// C = alpha K + beta M (Eq 4) is diagonal too, so Eq (5) splits into one scalar three-level
// recursion per mode:
//   q+ (1/dt^2 + c/(2 dt) + w^2/3) = g_bar + q (2/dt^2 - w^2/3) + q- (-1/dt^2 + c/(2 dt) - w^2/3),
// c = alpha w^2 + beta, g_bar = Phi^T (f+ + f + f-)/3 (Eq 9 per mode), and the reactions of Eq (10)
// follow per reaction functional from the modal coordinates alone.
//
// Contract
// - Units SI; vectors have the reduced model's DOF layout (3 * keypoint + c); forces are APPLIED
//   keypoint forces (N), values at fixed DOFs go straight into the supports (as ThreeLevelIntegrator).
// - ModalRecursion: the per-mode recursion and the projected Eq (10); shared by ModalIntegrator and
//   the weight-drop model of campaign/ (one home of the modal recursion).
// - ModalIntegrator: integrates by ModalRecursion the modes whose inertia the scheme feels
//   (w dt <= kQuasiStaticOmegaDt) and answers the others without inertia: with R = K_ff^-1 -
//   Phi W^-2 Phi^T (their flexibility) and z = R f, their displacement v follows Eq (5) with M = 0,
//   alpha (v+ - v-) / (2 dt) + (v+ + v + v-) / 3 = (z+ + z + z-) / 3 (every mode left out has the
//   time constant alpha + beta / w^2, taken as alpha), and u = Phi q + v. A constant load gives
//   exactly the static solution from the first step (a static correction). Only the free DOFs'
//   columns are kept (the fixed DOFs never move). The reactions are computed at the load-cell DOFs
//   only (Eq 10 on the modes and on v); reactions() is zero at the other fixed DOFs. Agreement with
//   ThreeLevelIntegrator on load cell and deformation: within 0.1 % of the signal's range
//   (tests/fem/modal_integrator_test.cpp; figures in docs/fem.md).
// - Cost per step: (modes + nonzero force entries) x free DOFs multiply-adds, no allocation of a
//   DOF-sized vector. Only the nonzero entries of the applied force are projected (the DEM's forces
//   are nonzero only on the keypoints in contact): g = Phi^T f and z = R f from those columns of
//   Phi^T and R. The load-cell share of v needs no product with v: v follows a scalar recursion per
//   DOF, so the load-cell rows of Eq (6)-(8) applied to v follow the same recursion driven by those
//   rows applied to z, i.e. by the precomputed columns of (Eq 6-8 rows) R at the loaded DOFs.
#pragma once

#include "demfem/fem/integrator.hpp"
#include "demfem/fem/model.hpp"
#include "demfem/study/study.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <functional>
#include <memory>
#include <vector>

namespace demfem::fem {

// Modes with w dt above this are integrated without inertia: their inertia term in Eq (6), 1/dt^2, is
// below 3 / (w dt)^2 = 0.3 % of their stiffness term w^2/3. (Truncating at the step's Nyquist limit
// w dt = pi instead leaves 0.2 % of the load-cell force in the heavily damped modes between, see
// docs/fem.md.)
constexpr double kQuasiStaticOmegaDt = 30.0;

class ModalRecursion {
 public:
  struct State {
    Eigen::VectorXd q, q_prev;                // modal coordinates at levels i, i-1
    Eigen::VectorXd reaction, reaction_prev;  // Eq (10) totals of each functional at levels i, i-1
  };

  // omega2: w_j^2 ((rad/s)^2) per M-normalized mode; reaction_stiffness, reaction_mass (rows:
  // functionals of the fixed-DOF forces, columns: modes): a^T K_cf phi_j and a^T M_cf phi_j.
  // Throws std::invalid_argument for dt <= 0, negative damping or mismatched sizes.
  ModalRecursion(const Eigen::ArrayXd& omega2, const Eigen::MatrixXd& reaction_stiffness, const Eigen::MatrixXd& reaction_mass,
                 RayleighDamping damping, double dt_s);

  int modeCount() const { return static_cast<int>(a2_.size()); }

  // At rest in static equilibrium under the modal force g: q = q- = g / w^2, reactions = K_cf Phi q.
  State atRest(const Eigen::VectorXd& modal_force) const;
  // Eq (9) per mode with the modal force averaged over levels i+1, i, i-1, then Eq (10) per
  // functional: r+ = 3 (L1 q+ - L2 q - L3 q-) - r - r-.
  void step(const Eigen::VectorXd& mean_modal_force, State& s) const;

 private:
  Eigen::ArrayXd omega2_, inv_a1_, a2_, a3_;
  Eigen::MatrixXd stiffness_, l1_, l2_, l3_;
};

// The part of ModalIntegrator's set-up that depends on the model and the step alone (not on the
// damping): the modes it integrates, w dt <= max_omega_dt (Spectra; at least one), and the residual
// flexibility R = K_ff^-1 - Phi W^-2 Phi^T of the others (dense Cholesky of K_ff), on the free DOFs.
// Seconds of processor time on the paper's tools; fem/reduction_cache.hpp keeps it on disk.
struct ModalBasis {
  Eigen::ArrayXd omega2;     // w_j^2 ((rad/s)^2) per mode, ascending
  Eigen::MatrixXd phi;       // free DOFs x modes, M-normalized
  Eigen::MatrixXd residual;  // R, free x free, symmetric
  double highest_mode_Hz = 0;
};

// Throws std::invalid_argument for dt <= 0, max_omega_dt <= 0 or a model whose K is not positive
// definite on the free DOFs.
ModalBasis modalBasis(const ReducedModel& model, double dt_s, double max_omega_dt = kQuasiStaticOmegaDt);

class ModalIntegrator : public TimeIntegrator {
 public:
  // With modalBasis(model, dt_s, max_omega_dt). Throws as modalBasis() and for negative damping.
  ModalIntegrator(const ReducedModel& model, double dt_s, RayleighDamping damping, double max_omega_dt = kQuasiStaticOmegaDt);
  // With a basis modalBasis(model, dt_s, ...) returned (or the reduction cache read back). Throws
  // std::invalid_argument for dt <= 0, negative damping or a basis whose sizes do not fit the model.
  ModalIntegrator(const ReducedModel& model, ModalBasis basis, double dt_s, RayleighDamping damping);

  void start(const Eigen::VectorXd& f0) override;
  const Eigen::VectorXd& step(const Eigen::VectorXd& applied_next) override;
  const Eigen::VectorXd& displacement() const override { return u_; }
  // Force of the supports on the tool at the load-cell DOFs (N); zero at every other DOF.
  Eigen::VectorXd reactions() const override;
  SavedIntegratorState save() const override;
  void restore(const SavedIntegratorState& state) override;

  int modeCount() const { return recursion_->modeCount(); }
  double highestModeHz() const { return highest_mode_Hz_; }

 private:
  void gatherLoad(const Eigen::VectorXd& f);
  void assemble();

  int dofs_ = 0;
  std::vector<int> free_, cell_;       // free DOFs; load-cell DOFs (reaction functionals)
  Eigen::MatrixXd phi_;                // free x modes
  Eigen::MatrixXd phi_t_;              // Phi^T: modes x free (a column per free DOF)
  Eigen::MatrixXd residual_;           // R on the free DOFs (symmetric; a column per free DOF)
  Eigen::MatrixXd cell_stiffness_;     // K_cf: load-cell DOFs x free DOFs
  Eigen::MatrixXd cell_terms_residual_;  // [A1; A2; A3] (Eq 6-8, load-cell rows) R: 3 cells x free
  std::unique_ptr<ModalRecursion> recursion_;
  double lag_a1_ = 0, lag_a3_ = 0;     // Eq (5) without inertia, on the modes left out
  double highest_mode_Hz_ = 0;
  std::int64_t step_ = 0;
  ModalRecursion::State modal_;
  Eigen::VectorXd g_, g_prev_, g_next_;  // modal forces of levels i, i-1, i+1
  Eigen::VectorXd z_, z_prev_, z_next_;  // R f of levels i, i-1, i+1 (free DOFs)
  Eigen::VectorXd v_, v_prev_, v_next_;  // residual displacement of levels i, i-1, i+1 (free DOFs)
  Eigen::VectorXd y_, y_prev_, y_next_;  // [A1; A2; A3] z at the load-cell rows, levels i, i-1, i+1
  Eigen::VectorXd p_, p_prev_, p_next_;  // [A1; A2; A3] v at the load-cell rows, levels i, i-1, i+1
  Eigen::VectorXd r_, r_prev_, r_next_;  // Eq (10) load-cell forces of the residual, levels i, i-1, i+1
  Eigen::VectorXd applied_, u_;        // applied force and displacement of level i
  Eigen::VectorXd u_free_;             // u of level i on the free DOFs
  Eigen::VectorXd cell_reaction_;      // reactions at cell_ of level i
  std::vector<Eigen::Index> loaded_;   // free-DOF indices of the nonzero entries of the last applied force
  Eigen::VectorXd loaded_force_;       // those entries (N)
};

// Modes and static solutions of a reduced model whose stiffness is K(e, s) = e (K_ref - S) + s S, S
// the ground springs of model.constraints.springs (the compliant clamp, model.hpp): the material
// stiffness scaled by e (E / E_ref at fixed nu) and the springs by s (k_theta / k_ref), each pair
// without a new eigen solution of the free DOFs (docs/fem.md, Compliant clamp).
// - Ritz basis V: the lowest `modes` modes of the reference model (e = s = 1) and its static
//   responses to unit forces at the spring DOFs, M-orthonormalized. K(e, s) is projected on V
//   exactly (V^T K V = e V^T K_ref V + (s - e) V^T S V), so modes(e, s) costs an eigen problem of
//   the basis size (about modes + springs).
// - solveStatic(e, s, f) is exact (Woodbury identity on the spring DOFs):
//   K(e,s)^-1 = (1/e) (K_ref + d S)^-1, d = (s - e) / e, and with G = K_ref^-1 P, S = P D P^T,
//   (K_ref + d P D P^T)^-1 f = u_ref - G (I + d D P^T G)^-1 d D P^T u_ref, u_ref = K_ref^-1 f.
// Pre: `model` has springs; e > 0, s > 0. Throws std::invalid_argument otherwise or for a count
// outside 1..basis size.
class SpringRitzBasis {
 public:
  SpringRitzBasis(const ReducedModel& model, int modes);
  int size() const { return static_cast<int>(V_.cols()); }
  // The lowest `count` Ritz modes of K(e, s) with the model's M (shapes on all DOFs, M-normalized).
  Modes modes(double e, double s, int count) const;
  // K(e, s) u = f + reactions with the model's constraints (as solveStatic(ReducedModel, f)).
  StaticSolution solveStatic(double e, double s, const Eigen::VectorXd& f) const;

 private:
  Eigen::VectorXd solveReference(const Eigen::VectorXd& f_free) const;

  int dofs_ = 0;
  std::vector<int> free_;
  std::vector<Eigen::Index> spring_;  // spring DOFs as free-DOF indices
  Eigen::VectorXd spring_stiffness_;  // D (N/m) at s = 1
  Eigen::MatrixXd K_;                 // K_ref on all DOFs (for the reactions)
  Eigen::MatrixXd K_ff_;
  Eigen::LLT<Eigen::MatrixXd> K_ff_factor_;
  Eigen::MatrixXd G_;                 // K_ref^-1 P (free x springs)
  Eigen::MatrixXd V_;                 // Ritz basis (free x size), V^T M V = I
  Eigen::MatrixXd K_V_, S_V_;         // V^T K_ref V, V^T S V
};

// The integrator a study asks for (study fem.integration): Full -> ThreeLevelIntegrator,
// Modal -> ModalIntegrator on the basis `modal_basis` returns (modalBasis(model, dt_s) when empty;
// not called for Full).
std::unique_ptr<TimeIntegrator> makeIntegrator(const ReducedModel& model, double dt_s, RayleighDamping damping,
                                               study::FemIntegration integration,
                                               const std::function<ModalBasis()>& modal_basis = {});

}  // namespace demfem::fem

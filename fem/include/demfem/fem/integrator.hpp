// demfem time integration of the reduced tool model: paper Eq (3)-(10) (docs/architecture.md section 4).
//
// The scheme (Eq 5) is Newmark's method with beta = 1/3, gamma = 1/2 written in three-level form:
//   M (u+ - 2u + u-)/dt^2 + C (u+ - u-)/(2 dt) + K (u+ + u + u-)/3 = (f+ + f + f-)/3
// with C = alpha K + beta M (Eq 4). It is unconditionally stable, has no numerical dissipation and a
// period elongation given by cos(w_h dt) = (1 - w^2 dt^2 / 6) / (1 + w^2 dt^2 / 3)
// (predictedDiscreteFrequency()).
//
// Contract
// - Units: SI. dt in s, alpha in s (stiffness-proportional), beta in 1/s (mass-proportional); the
//   damping ratio of a mode of angular frequency w is alpha w / 2 + beta / (2 w). Table 3's
//   alpha = 0.55 is read as 0.55 ms = 5.5e-4 s (docs/architecture.md section 4; docs/fem.md).
// - Vectors have the reduced model's DOF layout (3 * keypoint + c), i.e. an adapter::NodeArray.
// - Forces passed to step() are the APPLIED keypoint forces (N), e.g. the DEM's nodeForces(); the
//   values at fixed DOFs are allowed (they go straight into the supports). The fixed DOFs stay at
//   zero displacement.
// - A1 (Eq 6) restricted to the free DOFs is factorized once (dense Cholesky) at construction;
//   A2, A3 (Eq 7, 8) are kept for the products.
// - Reactions (Eq 10): the total nodal force at the fixed DOFs is advanced by Eq (10) and the
//   reaction is that total minus the applied force (force of the supports on the tool). The
//   recursion f+ + f + f- = 3(...) has a neutral period-3 mode; start() initialises f and f- from a
//   state at rest in static equilibrium (the state Newmark's one-step form would have), so the
//   sequence equals Newmark's instantaneous reactions and carries no period-3 component.
// - Call sequence (the coupled cycle of Fig. 3, docs/architecture.md section 1):
//     ReducedModel model = reduce(buildFullModel(tool));
//     ThreeLevelIntegrator integ(model, study.fem.dt_s, {tool.fem.alpha_s, tool.fem.beta_per_s});
//     integ.start(f0);                         // at rest, static equilibrium under f0 (often 0)
//     loop: f = dem.nodeForces(...)            // applied forces for the new time level
//           u = integ.step(f);                 // Eq (9): displacements at t + dt; Eq (10) reactions
//           dem.setNodePositions(keypoints + u); dem.simulate(dt);
//           sensors.read(u, integ.reactions());  // Sensors sensors(model, tool)
//   state()/setState() save and restore everything step() depends on (checkpoint/restart).
#pragma once

#include "demfem/fem/model.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Core>

#include <cstdint>
#include <memory>
#include <vector>

namespace demfem::fem {

struct RayleighDamping {
  double alpha_s = 0;     // C = alpha K + beta M (Eq 4)
  double beta_per_s = 0;
};

// Eq (4) and Eq (6)-(8) for a mass m and stiffness k: dense matrices, or the scalars of one
// M-normalized mode (m = 1, k = w^2), or a reaction functional's rows of M and K times a mode.
template <class T>
struct ThreeLevelTerms {
  T A1, A2, A3;
};
template <class T>
ThreeLevelTerms<T> threeLevelTerms(const T& m, const T& k, RayleighDamping damping, double dt_s) {
  const T c = damping.alpha_s * k + damping.beta_per_s * m;  // Eq (4)
  const double dt2 = dt_s * dt_s;
  return {m / dt2 + c / (2 * dt_s) + k / 3,   // Eq (6)
          2 * m / dt2 - k / 3,                // Eq (7)
          -m / dt2 + c / (2 * dt_s) - k / 3}; // Eq (8)
}

// What a checkpoint keeps of an integrator: its step index and its state vectors (layout private to
// the integrator; restore() checks the sizes).
struct SavedIntegratorState {
  std::int64_t step = 0;
  std::vector<Eigen::VectorXd> vectors;
};

// The time integration of a reduced tool model as the coupled cycle uses it (Fig. 3): the full
// three-level form (ThreeLevelIntegrator) or its modal form (ModalIntegrator, modal.hpp). Vectors
// have the reduced model's DOF layout; forces are the APPLIED keypoint forces (N).
class TimeIntegrator {
 public:
  virtual ~TimeIntegrator() = default;
  // At rest in static equilibrium under the applied force f0 (Eq 2); step index 0.
  virtual void start(const Eigen::VectorXd& f0) = 0;
  // Advances one step with the applied force of the new time level; returns u_{i+1} (m).
  virtual const Eigen::VectorXd& step(const Eigen::VectorXd& applied_next) = 0;
  virtual const Eigen::VectorXd& displacement() const = 0;
  // Force of the supports on the tool (N), at least at every load-cell DOF (what Sensors reads).
  virtual Eigen::VectorXd reactions() const = 0;
  virtual SavedIntegratorState save() const = 0;
  // Throws std::invalid_argument if `state` was not saved by an integrator of this kind and size.
  virtual void restore(const SavedIntegratorState& state) = 0;
};

// Everything the three-level recursion carries from step to step.
struct IntegratorState {
  std::int64_t step = 0;            // index i of the current time level (t = step * dt)
  Eigen::VectorXd u, u_prev;        // u_i, u_{i-1} (m), all reduced DOFs
  Eigen::VectorXd f, f_prev;        // total nodal force f_i, f_{i-1} (N): applied + reaction
  Eigen::VectorXd applied;          // applied part of f_i (N); f - applied = reactions at level i
};

class ThreeLevelIntegrator : public TimeIntegrator {
 public:
  // Throws std::invalid_argument for dt <= 0, negative damping, or if A1 on the free DOFs is not
  // positive definite.
  ThreeLevelIntegrator(const ReducedModel& model, double dt_s, RayleighDamping damping);

  // At rest in static equilibrium under the applied force `f0` (Eq 2): u_0 = u_{-1} = K^-1 f0,
  // f_0 = f_{-1} = f0 + reactions. step index 0.
  void start(const Eigen::VectorXd& f0) override;

  // Eq (9) with the applied force f_{i+1}; then Eq (10) for the fixed DOFs. Returns u_{i+1}.
  const Eigen::VectorXd& step(const Eigen::VectorXd& applied_next) override;

  const Eigen::VectorXd& displacement() const override { return state_.u; }
  // Force of the supports on the tool at every DOF (N), nonzero only at fixed DOFs.
  Eigen::VectorXd reactions() const override;
  SavedIntegratorState save() const override;
  void restore(const SavedIntegratorState& state) override;
  double time() const { return static_cast<double>(state_.step) * dt_; }
  double dt() const { return dt_; }

  const IntegratorState& state() const { return state_; }
  // Restores a saved state (same model and dt). Throws std::invalid_argument on a size mismatch.
  void setState(const IntegratorState& state);

 private:
  double dt_;
  std::vector<int> free_, fixed_;
  Eigen::MatrixXd A1_, A2_, A3_;            // Eq (6)-(8), all DOFs
  Eigen::LLT<Eigen::MatrixXd> A1_free_;     // A1 on the free DOFs, factorized once
  Eigen::MatrixXd K_;                       // for start(): static equilibrium and its reactions
  Eigen::LLT<Eigen::MatrixXd> K_free_;
  IntegratorState state_;
};

// The discrete angular frequency (rad/s) of the scheme for a mode of angular frequency `omega`
// (undamped): cos(w_h dt) = (1 - w^2 dt^2 / 6) / (1 + w^2 dt^2 / 3).
double predictedDiscreteFrequency(double omega_rad_s, double dt_s);

}  // namespace demfem::fem

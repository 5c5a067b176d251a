#include "demfem/fem/integrator.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace demfem::fem {

ThreeLevelIntegrator::ThreeLevelIntegrator(const ReducedModel& model, double dt_s, RayleighDamping damping)
    : dt_(dt_s), free_(model.freeDofs()), fixed_(model.constraints.fixed_dofs) {
  if (!(dt_s > 0)) throw std::invalid_argument("integrator: dt must be > 0 s (got " + std::to_string(dt_s) + ")");
  if (!(damping.alpha_s >= 0) || !(damping.beta_per_s >= 0))
    throw std::invalid_argument("integrator: Rayleigh alpha (s) and beta (1/s) must be >= 0");
  ThreeLevelTerms<Eigen::MatrixXd> terms = threeLevelTerms(model.M, model.K, damping, dt_s);  // Eq (4), (6)-(8)
  A1_ = std::move(terms.A1);
  A2_ = std::move(terms.A2);
  A3_ = std::move(terms.A3);
  A1_free_.compute(A1_(free_, free_));
  if (A1_free_.info() != Eigen::Success) throw std::invalid_argument("integrator: A1 (Eq 6) is not positive definite on the free DOFs");
  K_ = model.K;
  K_free_.compute(K_(free_, free_));
  if (K_free_.info() != Eigen::Success) throw std::invalid_argument("integrator: K is not positive definite on the free DOFs (tool not held?)");
  start(Eigen::VectorXd::Zero(model.dofCount()));
}

void ThreeLevelIntegrator::start(const Eigen::VectorXd& f0) {
  if (f0.size() != A1_.rows()) throw std::invalid_argument("integrator start: force vector has the wrong size");
  state_.step = 0;
  state_.u = Eigen::VectorXd::Zero(f0.size());
  const Eigen::VectorXd u_free = K_free_.solve(Eigen::VectorXd(f0(free_)));
  state_.u(free_) = u_free;  // Eq (2): at rest, static equilibrium
  state_.u_prev = state_.u;
  state_.applied = f0;
  state_.f = f0;
  state_.f(fixed_) = K_(fixed_, Eigen::all) * state_.u;  // total nodal force = applied + reaction
  state_.f_prev = state_.f;
}

const Eigen::VectorXd& ThreeLevelIntegrator::step(const Eigen::VectorXd& applied_next) {
  if (applied_next.size() != A1_.rows())
    throw std::invalid_argument("integrator step: force vector has " + std::to_string(applied_next.size()) + " entries, expected " +
                                std::to_string(A1_.rows()));
  if (!applied_next.allFinite()) throw std::invalid_argument("integrator step: force vector contains NaN or infinity");
  // Free rows: the total force is the applied force.
  Eigen::VectorXd f_next = applied_next;
  const Eigen::VectorXd history = A2_ * state_.u + A3_ * state_.u_prev;
  const Eigen::VectorXd rhs = (f_next + state_.f + state_.f_prev) / 3 + history;  // Eq (9), bracket
  Eigen::VectorXd u_next = Eigen::VectorXd::Zero(rhs.size());
  const Eigen::VectorXd u_free = A1_free_.solve(Eigen::VectorXd(rhs(free_)));
  u_next(free_) = u_free;  // Eq (9)
  // Eq (10) at the fixed DOFs: f_{i+1} = 3 (A1 u_{i+1} - A2 u_i - A3 u_{i-1}) - f_i - f_{i-1}.
  f_next(fixed_) = 3 * (A1_(fixed_, free_) * u_next(free_) - history(fixed_)) - state_.f(fixed_) - state_.f_prev(fixed_);
  state_.u_prev = std::move(state_.u);
  state_.u = std::move(u_next);
  state_.f_prev = std::move(state_.f);
  state_.f = std::move(f_next);
  state_.applied = applied_next;
  ++state_.step;
  return state_.u;
}

Eigen::VectorXd ThreeLevelIntegrator::reactions() const {
  Eigen::VectorXd r = Eigen::VectorXd::Zero(state_.f.size());
  r(fixed_) = state_.f(fixed_) - state_.applied(fixed_);
  return r;
}

void ThreeLevelIntegrator::setState(const IntegratorState& state) {
  const auto n = A1_.rows();
  if (state.u.size() != n || state.u_prev.size() != n || state.f.size() != n || state.f_prev.size() != n || state.applied.size() != n)
    throw std::invalid_argument("integrator setState: state vectors must have " + std::to_string(n) + " entries");
  state_ = state;
}

SavedIntegratorState ThreeLevelIntegrator::save() const {
  return {state_.step, {state_.u, state_.u_prev, state_.f, state_.f_prev, state_.applied}};
}

void ThreeLevelIntegrator::restore(const SavedIntegratorState& saved) {
  if (saved.vectors.size() != 5) throw std::invalid_argument("integrator restore: not the state of a full (three-level) integration");
  setState({saved.step, saved.vectors[0], saved.vectors[1], saved.vectors[2], saved.vectors[3], saved.vectors[4]});
}

double predictedDiscreteFrequency(double omega_rad_s, double dt_s) {
  const double W2 = omega_rad_s * omega_rad_s * dt_s * dt_s;
  return std::acos((1 - W2 / 6) / (1 + W2 / 3)) / dt_s;
}

}  // namespace demfem::fem

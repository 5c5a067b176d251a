#include "demfem/fem/modal.hpp"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include <cmath>
#include <numbers>
#include <stdexcept>
#include <string>

namespace demfem::fem {

ModalRecursion::ModalRecursion(const Eigen::ArrayXd& omega2, const Eigen::MatrixXd& reaction_stiffness,
                               const Eigen::MatrixXd& reaction_mass, RayleighDamping damping, double dt_s)
    : omega2_(omega2), stiffness_(reaction_stiffness) {
  if (!(dt_s > 0)) throw std::invalid_argument("modal recursion: dt must be > 0 s (got " + std::to_string(dt_s) + ")");
  if (!(damping.alpha_s >= 0) || !(damping.beta_per_s >= 0))
    throw std::invalid_argument("modal recursion: Rayleigh alpha (s) and beta (1/s) must be >= 0");
  if (reaction_stiffness.cols() != omega2.size() || reaction_mass.cols() != omega2.size() ||
      reaction_mass.rows() != reaction_stiffness.rows())
    throw std::invalid_argument("modal recursion: the reaction functionals must have one column per mode");
  const Eigen::ArrayXd ones = Eigen::ArrayXd::Ones(omega2.size());
  const ThreeLevelTerms<Eigen::ArrayXd> modal = threeLevelTerms(ones, omega2, damping, dt_s);  // Eq (6)-(8) per mode
  inv_a1_ = modal.A1.inverse();
  a2_ = modal.A2;
  a3_ = modal.A3;
  ThreeLevelTerms<Eigen::MatrixXd> reaction = threeLevelTerms(reaction_mass, reaction_stiffness, damping, dt_s);
  l1_ = std::move(reaction.A1);
  l2_ = std::move(reaction.A2);
  l3_ = std::move(reaction.A3);
}

ModalRecursion::State ModalRecursion::atRest(const Eigen::VectorXd& modal_force) const {
  if (modal_force.size() != omega2_.size()) throw std::invalid_argument("modal recursion: modal force has the wrong size");
  State s;
  s.q = (modal_force.array() / omega2_).matrix();  // Eq (2) per mode
  s.q_prev = s.q;
  s.reaction = stiffness_ * s.q;
  s.reaction_prev = s.reaction;
  return s;
}

void ModalRecursion::step(const Eigen::VectorXd& mean_modal_force, State& s) const {
  Eigen::VectorXd q_next = ((mean_modal_force.array() + a2_ * s.q.array() + a3_ * s.q_prev.array()) * inv_a1_).matrix();  // Eq (9)
  Eigen::VectorXd r_next = 3 * (l1_ * q_next - l2_ * s.q - l3_ * s.q_prev) - s.reaction - s.reaction_prev;     // Eq (10)
  s.q_prev = std::move(s.q);
  s.q = std::move(q_next);
  s.reaction_prev = std::move(s.reaction);
  s.reaction = std::move(r_next);
}

namespace {

// The modes of `model` with w dt <= max_omega_dt, at least one: Spectra's lowest modes, asked for in
// growing numbers until one above the limit appears.
Modes resolvedModes(const ReducedModel& model, double dt_s, double max_omega_dt) {
  const int free_count = static_cast<int>(model.freeDofs().size());
  const double limit_Hz = max_omega_dt / dt_s / (2 * std::numbers::pi);
  for (int count = std::min(8, free_count - 1);; count = std::min(2 * count, free_count - 1)) {
    Modes modes = naturalModes(model, count);
    int kept = 0;
    while (kept < count && modes.frequencies_Hz[static_cast<std::size_t>(kept)] <= limit_Hz) ++kept;
    if (kept < count || count == free_count - 1) {
      kept = std::max(kept, 1);
      modes.frequencies_Hz.resize(static_cast<std::size_t>(kept));
      modes.shapes.conservativeResize(Eigen::NoChange, kept);
      return modes;
    }
  }
}

// out += a0 w0 + a1 w1 + a2 w2 + a3 w3 over `rows` entries, summed left to right (as Eigen's
// expression would); compiled for AVX2 too, chosen at run time.
[[gnu::target_clones("avx2", "default")]] void addFour(double* __restrict out, const double* a0, const double* a1, const double* a2,
                                                       const double* a3, const double (&w)[4], Eigen::Index rows) {
  for (Eigen::Index i = 0; i < rows; ++i) out[i] += a0[i] * w[0] + a1[i] * w[1] + a2[i] * w[2] + a3[i] * w[3];
}

// out = sum_k A.col(columns[k]) * weights(k): the product of A's columns at the loaded DOFs with
// their forces, four columns per pass over `out` (no gathered copy of the columns).
void addColumns(const Eigen::MatrixXd& A, const std::vector<Eigen::Index>& columns, const Eigen::VectorXd& weights,
                Eigen::VectorXd& out) {
  out.setZero(A.rows());
  const std::size_t n = columns.size();
  std::size_t k = 0;
  for (; k + 4 <= n; k += 4) {
    const auto w = [&](std::size_t j) { return weights(static_cast<Eigen::Index>(j)); };
    const double four[4] = {w(k), w(k + 1), w(k + 2), w(k + 3)};
    addFour(out.data(), A.col(columns[k]).data(), A.col(columns[k + 1]).data(), A.col(columns[k + 2]).data(),
            A.col(columns[k + 3]).data(), four, A.rows());
  }
  for (; k < n; ++k) out.noalias() += A.col(columns[k]) * weights(static_cast<Eigen::Index>(k));
}

}  // namespace

ModalBasis modalBasis(const ReducedModel& model, double dt_s, double max_omega_dt) {
  if (!(dt_s > 0)) throw std::invalid_argument("modal integrator: dt must be > 0 s (got " + std::to_string(dt_s) + ")");
  const std::vector<int> free = model.freeDofs();
  const Eigen::MatrixXd K_ff = model.K(free, free);
  Eigen::LLT<Eigen::MatrixXd> K_factor(K_ff);
  if (K_factor.info() != Eigen::Success)
    throw std::invalid_argument("modal integrator: K is not positive definite on the free DOFs (tool not held?)");
  if (!(max_omega_dt > 0)) throw std::invalid_argument("modal integrator: the resolved w dt must be > 0");
  const Modes modes = resolvedModes(model, dt_s, max_omega_dt);
  ModalBasis b;
  b.highest_mode_Hz = modes.frequencies_Hz.back();
  b.phi = modes.shapes(free, Eigen::all);
  b.omega2.resize(b.phi.cols());
  for (Eigen::Index j = 0; j < b.omega2.size(); ++j)
    b.omega2(j) = std::pow(2 * std::numbers::pi * modes.frequencies_Hz[static_cast<std::size_t>(j)], 2);
  // Residual flexibility of the modes left out: R = K_ff^-1 - Phi W^-2 Phi^T.
  b.residual = K_factor.solve(Eigen::MatrixXd::Identity(K_ff.rows(), K_ff.cols()));
  const Eigen::MatrixXd phi_t = b.phi.transpose();
  b.residual -= b.phi * b.omega2.inverse().matrix().asDiagonal() * phi_t;
  b.residual = 0.5 * (b.residual + b.residual.transpose()).eval();
  return b;
}

ModalIntegrator::ModalIntegrator(const ReducedModel& model, double dt_s, RayleighDamping damping, double max_omega_dt)
    : ModalIntegrator(model, modalBasis(model, dt_s, max_omega_dt), dt_s, damping) {}

ModalIntegrator::ModalIntegrator(const ReducedModel& model, ModalBasis basis, double dt_s, RayleighDamping damping)
    : dofs_(model.dofCount()), free_(model.freeDofs()), cell_(model.constraints.load_cell_dofs) {
  if (!(dt_s > 0)) throw std::invalid_argument("modal integrator: dt must be > 0 s (got " + std::to_string(dt_s) + ")");
  const auto free_count = static_cast<Eigen::Index>(free_.size());
  if (basis.phi.rows() != free_count || basis.phi.cols() < 1 || basis.omega2.size() != basis.phi.cols() ||
      basis.residual.rows() != free_count || basis.residual.cols() != free_count)
    throw std::invalid_argument("modal integrator: the modal basis (" + std::to_string(basis.phi.rows()) + " x " +
                                std::to_string(basis.phi.cols()) + " modes, R " + std::to_string(basis.residual.rows()) +
                                " DOFs) does not fit the model's " + std::to_string(free_count) + " free DOFs");
  highest_mode_Hz_ = basis.highest_mode_Hz;
  phi_ = std::move(basis.phi);
  phi_t_ = phi_.transpose();
  const Eigen::ArrayXd omega2 = std::move(basis.omega2);
  residual_ = std::move(basis.residual);
  const Eigen::MatrixXd K_cf = model.K(cell_, free_), M_cf = model.M(cell_, free_);
  cell_stiffness_ = K_cf;
  const ThreeLevelTerms<Eigen::MatrixXd> cell_terms = threeLevelTerms(M_cf, K_cf, damping, dt_s);  // Eq (6)-(8), load-cell rows
  const auto cells = static_cast<Eigen::Index>(cell_.size());
  cell_terms_residual_.resize(3 * cells, residual_.cols());
  cell_terms_residual_.middleRows(0, cells).noalias() = cell_terms.A1 * residual_;
  cell_terms_residual_.middleRows(cells, cells).noalias() = cell_terms.A2 * residual_;
  cell_terms_residual_.middleRows(2 * cells, cells).noalias() = cell_terms.A3 * residual_;
  recursion_ = std::make_unique<ModalRecursion>(omega2, K_cf * phi_, M_cf * phi_, damping, dt_s);
  lag_a1_ = damping.alpha_s / (2 * dt_s) + 1.0 / 3;
  lag_a3_ = damping.alpha_s / (2 * dt_s) - 1.0 / 3;
  u_ = Eigen::VectorXd::Zero(dofs_);
  loaded_.reserve(free_.size());
  loaded_force_.resize(static_cast<Eigen::Index>(free_.size()));
  start(Eigen::VectorXd::Zero(dofs_));
}

// loaded_, loaded_force_: the free DOFs where `f` is nonzero and its values there.
void ModalIntegrator::gatherLoad(const Eigen::VectorXd& f) {
  loaded_.clear();
  for (std::size_t i = 0; i < free_.size(); ++i) {
    const double v = f(free_[i]);
    if (v == 0) continue;
    loaded_force_(static_cast<Eigen::Index>(loaded_.size())) = v;
    loaded_.push_back(static_cast<Eigen::Index>(i));
  }
}

// u and the load-cell reactions of level i from the modal and residual states of that level.
void ModalIntegrator::assemble() {
  u_free_.noalias() = phi_ * modal_.q;
  u_free_ += v_;
  for (std::size_t i = 0; i < free_.size(); ++i) u_(free_[i]) = u_free_(static_cast<Eigen::Index>(i));
  cell_reaction_ = modal_.reaction + r_;
  for (std::size_t c = 0; c < cell_.size(); ++c) cell_reaction_(static_cast<Eigen::Index>(c)) -= applied_(cell_[c]);  // total minus applied (Eq 10)
}

void ModalIntegrator::start(const Eigen::VectorXd& f0) {
  if (f0.size() != dofs_) throw std::invalid_argument("modal integrator start: force vector has the wrong size");
  gatherLoad(f0);
  addColumns(phi_t_, loaded_, loaded_force_, g_);
  g_prev_ = g_;
  modal_ = recursion_->atRest(g_);
  addColumns(residual_, loaded_, loaded_force_, z_);
  z_prev_ = v_ = v_prev_ = z_;  // at rest: the static response
  addColumns(cell_terms_residual_, loaded_, loaded_force_, y_);
  y_prev_ = p_ = p_prev_ = y_;
  r_ = r_prev_ = cell_stiffness_ * v_;
  applied_ = f0;
  step_ = 0;
  assemble();
}

const Eigen::VectorXd& ModalIntegrator::step(const Eigen::VectorXd& applied_next) {
  if (applied_next.size() != dofs_)
    throw std::invalid_argument("modal integrator step: force vector has " + std::to_string(applied_next.size()) + " entries, expected " +
                                std::to_string(dofs_));
  if (!applied_next.allFinite()) throw std::invalid_argument("modal integrator step: force vector contains NaN or infinity");
  gatherLoad(applied_next);
  addColumns(phi_t_, loaded_, loaded_force_, g_next_);
  recursion_->step((g_next_ + g_ + g_prev_) / 3, modal_);  // Eq (9) per mode, Eq (10) per load-cell DOF
  addColumns(residual_, loaded_, loaded_force_, z_next_);
  addColumns(cell_terms_residual_, loaded_, loaded_force_, y_next_);
  // Eq (5) without inertia on the modes left out: alpha (v+ - v-) / (2 dt) + (v+ + v + v-) / 3 = R f_bar;
  // the same recursion carries the load-cell rows of Eq (6)-(8) applied to v.
  v_next_ = ((z_next_ + z_ + z_prev_) / 3 - v_ / 3 + lag_a3_ * v_prev_) / lag_a1_;
  p_next_ = ((y_next_ + y_ + y_prev_) / 3 - p_ / 3 + lag_a3_ * p_prev_) / lag_a1_;
  // Their share of the load-cell forces by Eq (10): 3 (A1 v+ - A2 v - A3 v-) - r - r-.
  const auto cells = static_cast<Eigen::Index>(cell_.size());
  r_next_ = 3 * (p_next_.head(cells) - p_.segment(cells, cells) - p_prev_.tail(cells)) - r_ - r_prev_;
  std::swap(g_prev_, g_), std::swap(g_, g_next_);
  std::swap(z_prev_, z_), std::swap(z_, z_next_);
  std::swap(v_prev_, v_), std::swap(v_, v_next_);
  std::swap(y_prev_, y_), std::swap(y_, y_next_);
  std::swap(p_prev_, p_), std::swap(p_, p_next_);
  std::swap(r_prev_, r_), std::swap(r_, r_next_);
  applied_ = applied_next;
  ++step_;
  assemble();
  return u_;
}

Eigen::VectorXd ModalIntegrator::reactions() const {
  Eigen::VectorXd r = Eigen::VectorXd::Zero(dofs_);
  r(cell_) = cell_reaction_;
  return r;
}

SavedIntegratorState ModalIntegrator::save() const {
  return {step_, {modal_.q, modal_.q_prev, modal_.reaction, modal_.reaction_prev, g_, g_prev_, z_, z_prev_, v_, v_prev_, y_, y_prev_, p_, p_prev_,
                  r_, r_prev_, applied_}};
}

void ModalIntegrator::restore(const SavedIntegratorState& saved) {
  const auto& v = saved.vectors;
  const Eigen::Index modes = recursion_->modeCount(), cells = static_cast<Eigen::Index>(cell_.size());
  const auto n = static_cast<Eigen::Index>(free_.size());
  const std::vector<Eigen::Index> sizes{modes, modes, cells, cells, modes, modes, n, n, n, n, 3 * cells, 3 * cells, 3 * cells, 3 * cells,
                                        cells, cells, dofs_};
  bool matches = v.size() == sizes.size();
  for (std::size_t i = 0; matches && i < sizes.size(); ++i) matches = v[i].size() == sizes[i];
  if (!matches)
    throw std::invalid_argument("modal integrator restore: not the state of a modal integration of this model (" +
                                std::to_string(modes) + " modes)");
  modal_ = {v[0], v[1], v[2], v[3]};
  g_ = v[4], g_prev_ = v[5], z_ = v[6], z_prev_ = v[7], v_ = v[8], v_prev_ = v[9];
  y_ = v[10], y_prev_ = v[11], p_ = v[12], p_prev_ = v[13], r_ = v[14], r_prev_ = v[15], applied_ = v[16];
  step_ = saved.step;
  assemble();
}

std::unique_ptr<TimeIntegrator> makeIntegrator(const ReducedModel& model, double dt_s, RayleighDamping damping,
                                               study::FemIntegration integration, const std::function<ModalBasis()>& modal_basis) {
  switch (integration) {
    case study::FemIntegration::Full:
      return std::make_unique<ThreeLevelIntegrator>(model, dt_s, damping);
    case study::FemIntegration::Modal:
      return std::make_unique<ModalIntegrator>(model, modal_basis ? modal_basis() : modalBasis(model, dt_s), dt_s, damping);
  }
  throw std::invalid_argument("unknown FEM integration");
}

}  // namespace demfem::fem

namespace demfem::fem {

SpringRitzBasis::SpringRitzBasis(const ReducedModel& model, int modes)
    : dofs_(model.dofCount()), free_(model.freeDofs()), K_(model.K) {
  if (model.constraints.springs.empty()) throw std::invalid_argument("spring Ritz basis: the model has no ground springs");
  std::vector<int> free_index(static_cast<std::size_t>(dofs_), -1);
  for (std::size_t i = 0; i < free_.size(); ++i) free_index[static_cast<std::size_t>(free_[i])] = static_cast<int>(i);
  spring_stiffness_.resize(static_cast<Eigen::Index>(model.constraints.springs.size()));
  for (const auto& [dof, stiffness] : model.constraints.springs) {
    if (free_index[static_cast<std::size_t>(dof)] < 0) throw std::invalid_argument("spring Ritz basis: a spring acts on a fixed DOF");
    spring_stiffness_(static_cast<Eigen::Index>(spring_.size())) = stiffness;
    spring_.push_back(free_index[static_cast<std::size_t>(dof)]);
  }
  K_ff_ = model.K(free_, free_);
  K_ff_factor_.compute(K_ff_);
  if (K_ff_factor_.info() != Eigen::Success)
    throw std::invalid_argument("spring Ritz basis: K is not positive definite on the free DOFs (tool not held?)");
  const auto n = static_cast<Eigen::Index>(free_.size()), p = static_cast<Eigen::Index>(spring_.size());
  G_.resize(n, p);
  for (Eigen::Index j = 0; j < p; ++j) G_.col(j) = solveReference(Eigen::VectorXd::Unit(n, spring_[static_cast<std::size_t>(j)]));
  const Modes reference = naturalModes(model, modes);
  const Eigen::MatrixXd M_ff = model.M(free_, free_);
  Eigen::MatrixXd krylov = M_ff * G_;  // the next block of the Krylov sequence K^-1 (M K^-1)^k P
  for (Eigen::Index j = 0; j < p; ++j) krylov.col(j) = solveReference(krylov.col(j));
  // M-orthonormal basis: the modes, then each static and Krylov vector M-orthogonalized against the
  // basis so far (Gram-Schmidt, twice for round-off) and kept unless it lies in the basis.
  V_.resize(n, modes + 2 * p);
  V_.leftCols(modes) = reference.shapes(free_, Eigen::all);
  Eigen::Index size = modes;
  for (const Eigen::MatrixXd* block : {&G_, &krylov})
    for (Eigen::Index j = 0; j < p; ++j) {
      Eigen::VectorXd v = block->col(j);
      const double norm0 = std::sqrt(v.dot(M_ff * v));
      for (int pass = 0; pass < 2; ++pass) v -= V_.leftCols(size) * (V_.leftCols(size).transpose() * (M_ff * v));
      const double norm = std::sqrt(v.dot(M_ff * v));
      if (norm > 1e-10 * norm0) V_.col(size++) = v / norm;
    }
  V_.conservativeResize(Eigen::NoChange, size);
  K_V_ = V_.transpose() * K_ff_ * V_;
  const Eigen::MatrixXd V_springs = V_(spring_, Eigen::all);
  S_V_ = V_springs.transpose() * spring_stiffness_.asDiagonal() * V_springs;
}

// K_ref^-1 f on the free DOFs with one step of iterative refinement (the thin plate's K is ill
// conditioned).
Eigen::VectorXd SpringRitzBasis::solveReference(const Eigen::VectorXd& f_free) const {
  Eigen::VectorXd x = K_ff_factor_.solve(f_free);
  x += K_ff_factor_.solve(f_free - K_ff_ * x);
  return x;
}

Modes SpringRitzBasis::modes(double e, double s, int count) const {
  if (!(e > 0) || !(s > 0)) throw std::invalid_argument("spring Ritz basis: stiffness scales must be > 0");
  if (count < 1 || count > size()) throw std::invalid_argument("spring Ritz basis: count must be in 1.." + std::to_string(size()));
  const Eigen::MatrixXd K_V = e * K_V_ + (s - e) * S_V_;  // V^T K(e, s) V, exact
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eigen(0.5 * (K_V + K_V.transpose()));  // V^T M V = I
  if (eigen.info() != Eigen::Success) throw std::runtime_error("spring Ritz basis: the projected eigen problem failed");
  Modes m;
  m.shapes = Eigen::MatrixXd::Zero(dofs_, count);
  m.shapes(free_, Eigen::all) = V_ * eigen.eigenvectors().leftCols(count);
  for (int j = 0; j < count; ++j) m.frequencies_Hz.push_back(std::sqrt(std::max(0.0, eigen.eigenvalues()(j))) / (2 * std::numbers::pi));
  return m;
}

StaticSolution SpringRitzBasis::solveStatic(double e, double s, const Eigen::VectorXd& f) const {
  if (!(e > 0) || !(s > 0)) throw std::invalid_argument("spring Ritz basis: stiffness scales must be > 0");
  if (f.size() != dofs_) throw std::invalid_argument("spring Ritz basis: force vector has the wrong size");
  const double d = (s - e) / e;
  const Eigen::VectorXd u_ref = solveReference(f(free_));
  const Eigen::MatrixXd dD = d * spring_stiffness_.asDiagonal();
  const Eigen::MatrixXd capacitance = Eigen::MatrixXd::Identity(G_.cols(), G_.cols()) + dD * G_(spring_, Eigen::all);
  const Eigen::VectorXd correction = capacitance.partialPivLu().solve(dD * u_ref(spring_));  // Woodbury
  StaticSolution out;
  out.displacement = Eigen::VectorXd::Zero(dofs_);
  out.displacement(free_) = (u_ref - G_ * correction) / e;
  // K(e, s) = e K_ref + (s - e) S; S acts on free DOFs only, so the reactions need e K_ref alone.
  out.reaction = e * (K_ * out.displacement) - f;
  for (int dof : free_) out.reaction(dof) = 0;
  return out;
}

}  // namespace demfem::fem

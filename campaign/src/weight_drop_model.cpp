// The calibration-weight test (fem/weight_drop.hpp, Section 2.10.1) in the modal basis of the reduced
// model, so that a change of E, alpha or beta costs one scalar recursion per mode (model.hpp).
//
// With Phi the M-normalized modes of (K_r, M_r + weight) on the free DOFs, u = Phi q + u_res. Eq (4)
// keeps the modes uncoupled and Eq (5) becomes one scalar three-level recursion per mode; the
// load-cell force follows Eq (10) on the fixed DOFs, projected on the load-cell sum (both
// fem::ModalRecursion, fem/modal.hpp). The modes kept are the lowest kModes; the others answer the
// step load quasi-statically (static correction u_res = K^-1 f - sum_j phi_j g_j / w_j^2, present
// from the first step), which keeps the static solution exact.
// Scaling: K_r = (E / E_ref) K_r,ref, so w^2, the load-cell stiffness terms and 1/u_res scale by
// E / E_ref while the mode shapes stay. A compliant clamp (fem/model.hpp) adds springs S on keypoint
// DOFs, which the reduction leaves untouched and which are proportional to k_theta:
// K_r = (E / E_ref) (K_ref - S_ref) + (k_theta / k_ref) S_ref. The reduction is kept per clamp
// layout and, per weight, a fem::SpringRitzBasis (the modes at the first E and k_theta plus the static
// responses to unit forces on the spring DOFs) gives the modes of every (E, k_theta) from a small
// eigen problem and the exact static solution by the Woodbury identity. Sensor gains scale the
// outputs only, so they change neither the reduction nor the basis. An added mass on the pan rows
// (weight_drop.added_mass_kg, tared) moves neither the load nor the static solution; its modes come
// from those without it by Rayleigh-Ritz on the kept modes (withAddedMass), one small eigen problem.
#include "demfem/campaign/model.hpp"

#include "demfem/fem/modal.hpp"
#include "demfem/fem/model.hpp"
#include "demfem/fem/reduction_cache.hpp"
#include "demfem/fem/sensors.hpp"
#include "demfem/fem/weight_drop.hpp"

#include <Eigen/Eigenvalues>
#include <nlohmann/json.hpp>

#include <cmath>
#include <future>
#include <map>
#include <mutex>

namespace demfem::campaign {
namespace {

constexpr int kModes = 40;
constexpr double kLeadIn_s = 0.1;  // rest before the weight is hung (model.hpp)

// A tool's reduced model at the reference modulus E_ref; depends on neither E, alpha nor beta.
struct Reduction {
  fem::ReducedModel model;
  double E_ref_Pa = 0;
  double k_ref_Nm_per_rad = 0;  // clamp spring of `model` (0: rigid clamp)
};

// The modal description of one weight on one reduction (at E_ref).
struct Basis {
  std::vector<double> omega2;       // w_j^2 (rad/s)^2
  std::vector<double> modal_force;  // g_j = phi_j^T f (N)
  std::vector<double> deformation;  // mm per unit q_j
  std::vector<double> cell_stiffness, cell_mass;  // c^T K_fa phi_j, c^T M_fa phi_j
  double residual_deformation_mm = 0;  // static correction of the deformation
  double residual_force_N = 0;         // static correction of the load-cell force
};

template <class T>
class OnceMap {
 public:
  template <class Make>
  std::shared_ptr<const T> get(const std::string& key, Make&& make) {
    std::shared_future<std::shared_ptr<const T>> future;
    std::promise<std::shared_ptr<const T>> promise;
    bool mine = false;
    {
      std::lock_guard lock(mutex_);
      auto it = entries_.find(key);
      if (it == entries_.end()) {
        future = promise.get_future().share();
        entries_.emplace(key, future);
        mine = true;
      } else {
        future = it->second;
      }
    }
    if (mine) {
      try {
        promise.set_value(std::make_shared<const T>(make()));
      } catch (...) {
        promise.set_exception(std::current_exception());
        std::lock_guard lock(mutex_);
        entries_.erase(key);
      }
    }
    return future.get();
  }
  int size() const {
    std::lock_guard lock(mutex_);
    return static_cast<int>(entries_.size());
  }

 private:
  mutable std::mutex mutex_;
  std::map<std::string, std::shared_future<std::shared_ptr<const T>>> entries_;
};

// The tool's JSON without what the reduction does not depend on.
std::string reductionKey(const study::Tool& tool) {
  study::Study s;
  s.kind = study::StudyKind::FemOnly;
  study::Tool t = tool;
  t.fem.youngs_Pa = 1;
  t.fem.alpha_s = 0;
  t.fem.beta_per_s = 0;
  t.motion = {};
  t.dem_material.clear();
  t.sensors = {};
  if (t.constraints.clamp_rotational_stiffness_Nm_per_rad) t.constraints.clamp_rotational_stiffness_Nm_per_rad = 1.0;
  s.tools = {t};
  return study::toJson(s)["tools"].dump();
}

std::vector<int> panDofs(const fem::ReducedModel& model, const study::WeightDrop& drop) {
  const double tip = model.keypoints.col(1).minCoeff();
  std::vector<int> dofs;
  for (int k = 0; k < model.keypointCount(); ++k)
    if (model.keypoints(k, 1) <= tip + drop.pan_rows_from_tip_m + 1e-9) dofs.push_back(3 * k + 2);
  if (dofs.empty()) throw std::invalid_argument("weight drop: no keypoint row within pan_rows_from_tip of the tip");
  return dofs;
}

Eigen::VectorXd weightLoad(const fem::ReducedModel& model, const std::vector<int>& pan, const study::WeightDrop& drop) {
  Eigen::VectorXd load = Eigen::VectorXd::Zero(model.dofCount());
  for (int dof : pan) load(dof) = -drop.mass_kg * fem::kStandardGravity_m_s2 / static_cast<double>(pan.size());  // as fem::simulateWeightDrop
  return load;
}

// The reduced model with the weight's mass, and the added mass already hanging there (its weight
// tared), lumped on the pan rows (Section 2.10.1, as fem::simulateWeightDrop).
fem::ReducedModel loadedModel(fem::ReducedModel model, const std::vector<int>& pan, const study::WeightDrop& drop) {
  fem::addLumpedMass(model, pan, (drop.mass_kg + drop.added_mass_kg) / static_cast<double>(pan.size()));
  return model;
}

// The modal description of the weight's load on `loaded` from its modes and its exact static solution.
// `model` gives the sensors, the load cell's rows of M and, times `stiffness_scale`, of K: the rows
// of fixed DOFs, which neither the pan's masses (free DOFs) nor the clamp springs (free DOFs) touch,
// so the reduction itself serves with the material's scale e (K = e (K_ref - S) + s S, header comment).
Basis basisOf(const fem::ReducedModel& model, double stiffness_scale, const study::Tool& tool, const fem::Modes& modes,
              const fem::StaticSolution& exact, const Eigen::VectorXd& load) {
  study::Tool ideal = tool;
  ideal.sensors = {};  // gains are applied to the outputs (integrate)
  const fem::Sensors sensors(model, ideal);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model.dofCount());
  // Load-cell functional c on the reactions (the sensor is linear in them).
  Eigen::VectorXd cell = Eigen::VectorXd::Zero(model.dofCount());
  for (int dof : model.constraints.fixed_dofs) {
    Eigen::VectorXd unit = zero;
    unit(dof) = 1;
    cell(dof) = sensors.read(zero, unit).load_cell_N;
  }
  const Eigen::RowVectorXd cell_K = stiffness_scale * (cell.transpose() * model.K), cell_M = cell.transpose() * model.M;
  Basis b;
  const fem::SensorReadings exact_reading = sensors.read(exact.displacement, exact.reaction);
  b.residual_deformation_mm = exact_reading.deformation_mm;
  b.residual_force_N = exact_reading.load_cell_N;
  for (std::size_t j = 0; j < modes.frequencies_Hz.size(); ++j) {
    const Eigen::VectorXd phi = modes.shapes.col(static_cast<Eigen::Index>(j));
    const double w = 2 * M_PI * modes.frequencies_Hz[j];
    b.omega2.push_back(w * w);
    b.modal_force.push_back(phi.dot(load));
    b.deformation.push_back(sensors.read(phi, zero).deformation_mm);
    b.cell_stiffness.push_back(cell_K.dot(phi));
    b.cell_mass.push_back(cell_M.dot(phi));
    const double q_static = b.modal_force.back() / b.omega2.back();
    b.residual_deformation_mm -= b.deformation.back() * q_static;
    b.residual_force_N -= b.cell_stiffness.back() * q_static;
  }
  return b;
}

int modeCount(const fem::ReducedModel& model) { return std::min(kModes, static_cast<int>(model.freeDofs().size()) / 2); }

// The modes and exact static solution of one weight without the added mass (a tared mass moves
// neither the load nor the static solution).
struct WeightSolution {
  fem::Modes modes;
  fem::StaticSolution exact;
};

study::WeightDrop withoutAddedMass(study::WeightDrop drop) {
  drop.added_mass_kg = 0;
  return drop;
}

// Rigid clamp: the loaded reduction at E_ref (E enters by scaling, integrate()).
WeightSolution rigidSolution(const Reduction& reduction, const study::WeightDrop& drop) {
  const std::vector<int> pan = panDofs(reduction.model, drop);
  const fem::ReducedModel loaded = loadedModel(reduction.model, pan, withoutAddedMass(drop));
  return {fem::naturalModes(loaded, modeCount(loaded)), fem::solveStatic(loaded, weightLoad(loaded, pan, drop))};
}

// The material's scale e = E / E_ref of a compliant clamp's model (header comment).
double materialScale(const Reduction& reduction, const study::Tool& tool) { return tool.fem.youngs_Pa / reduction.E_ref_Pa; }

// Compliant clamp: at the tool's E and k_theta from the weight's spring Ritz basis (no copy of the
// reduction: the basis holds what it needs).
WeightSolution sprungSolution(const Reduction& reduction, const fem::SpringRitzBasis& ritz, const study::Tool& tool, const study::WeightDrop& drop) {
  const double e = materialScale(reduction, tool);
  const double s = *tool.constraints.clamp_rotational_stiffness_Nm_per_rad / reduction.k_ref_Nm_per_rad;
  const Eigen::VectorXd load = weightLoad(reduction.model, panDofs(reduction.model, drop), drop);
  return {ritz.modes(e, s, modeCount(reduction.model)), ritz.solveStatic(e, s, load)};
}

// The modes with the added mass m_a on the pan rows from those without it, by Rayleigh-Ritz on the
// kept modes Phi: V^T K V = diag(w^2), V^T M V = I + (m_a / n) Phi_pan^T Phi_pan, one eigen
// problem of the mode count (docs/diagnosis.md, "added_mass").
fem::Modes withAddedMass(const fem::Modes& modes, const std::vector<int>& pan, double added_mass_kg) {
  if (added_mass_kg == 0) return modes;
  const auto count = static_cast<Eigen::Index>(modes.frequencies_Hz.size());
  Eigen::VectorXd omega2(count);
  for (Eigen::Index j = 0; j < count; ++j) omega2(j) = std::pow(2 * M_PI * modes.frequencies_Hz[static_cast<std::size_t>(j)], 2);
  const Eigen::MatrixXd at_pan = modes.shapes(pan, Eigen::all);
  const Eigen::MatrixXd mass = Eigen::MatrixXd::Identity(count, count) + added_mass_kg / static_cast<double>(pan.size()) * at_pan.transpose() * at_pan;
  const Eigen::GeneralizedSelfAdjointEigenSolver<Eigen::MatrixXd> eig(Eigen::MatrixXd(omega2.asDiagonal()), mass);
  fem::Modes out;
  out.shapes = modes.shapes * eig.eigenvectors();  // M-normalized with the added mass
  for (Eigen::Index j = 0; j < count; ++j) out.frequencies_Hz.push_back(std::sqrt(std::max(0.0, eig.eigenvalues()(j))) / (2 * M_PI));
  return out;
}

// The basis of one weight with its added mass, on the reduction (basisOf): the added mass enters
// through the modes only.
Basis weightBasis(const fem::ReducedModel& reduction, double stiffness_scale, const WeightSolution& solution, const study::Tool& tool,
                  const study::WeightDrop& drop) {
  const std::vector<int> pan = panDofs(reduction, drop);
  return basisOf(reduction, stiffness_scale, tool, withAddedMass(solution.modes, pan, drop.added_mass_kg), solution.exact,
                 weightLoad(reduction, pan, drop));
}

// Eq (5) and (10) per mode for the step load (fem::ModalRecursion); returns the recording's columns.
analysis::Recording integrate(const Basis& b, double scale, const study::Tool& tool, double dt, long steps) {
  analysis::Recording rec;
  rec.format = analysis::RecordingFormat::Calibrated;
  const auto lead_in = static_cast<long>(std::llround(kLeadIn_s / dt));
  for (long i = 0; i < lead_in; ++i) rec.time_s.push_back(static_cast<double>(i) * dt), rec.force.push_back(0), rec.deformation.push_back(0);
  const double t0 = static_cast<double>(lead_in) * dt;
  const auto modes = static_cast<Eigen::Index>(b.omega2.size());
  const Eigen::Map<const Eigen::ArrayXd> omega2(b.omega2.data(), modes);
  const Eigen::Map<const Eigen::RowVectorXd> cell_stiffness(b.cell_stiffness.data(), modes), cell_mass(b.cell_mass.data(), modes);
  const Eigen::Map<const Eigen::VectorXd> modal_force(b.modal_force.data(), modes), deformation_per_q(b.deformation.data(), modes);
  const fem::ModalRecursion recursion(scale * omega2, scale * cell_stiffness, cell_mass, {tool.fem.alpha_s, tool.fem.beta_per_s}, dt);
  fem::ModalRecursion::State state = recursion.atRest(Eigen::VectorXd::Zero(modes));
  rec.time_s.push_back(t0), rec.force.push_back(0), rec.deformation.push_back(0);
  const double residual_deformation = b.residual_deformation_mm / scale;
  for (long i = 1; i <= steps; ++i) {
    // Mean modal force of levels i, i-1, i-2: the weight hangs from level 1 on.
    const double levels = static_cast<double>(std::min<long>(i, 3)) / 3;
    recursion.step(levels * modal_force, state);
    rec.time_s.push_back(t0 + static_cast<double>(i) * dt);
    rec.force.push_back((state.reaction(0) + b.residual_force_N) * tool.sensors.force_gain);
    rec.deformation.push_back((residual_deformation + deformation_per_q.dot(state.q)) * tool.sensors.deformation_gain);
  }
  return rec;
}

}  // namespace

struct WeightDropModel::Impl {
  OnceMap<Reduction> reductions;
  OnceMap<fem::SpringRitzBasis> ritz;  // per clamp layout and weight
  OnceMap<WeightSolution> solutions;   // per weight (and E, k_theta with a clamp spring)
  OnceMap<Basis> bases;                // per solution and added mass
};

WeightDropModel::WeightDropModel() : impl_(std::make_unique<Impl>()) {}
WeightDropModel::~WeightDropModel() = default;

int WeightDropModel::basesBuilt() const { return impl_->reductions.size() + impl_->ritz.size() + impl_->solutions.size(); }

analysis::Recording WeightDropModel::run(const study::Study& study, const analysis::CaseKey& key, const std::filesystem::path&) {
  if (!study.weight_drop) throw std::invalid_argument("weight-drop model: study '" + study.name + "' has no /weight_drop");
  const study::Tool& tool = fem::deformableTool(study, "");
  const study::WeightDrop& drop = *study.weight_drop;
  const std::string tool_key = reductionKey(tool);
  const auto& clamp = tool.constraints.clamp_rotational_stiffness_Nm_per_rad;
  const auto reduction = impl_->reductions.get(tool_key, [&] {
    return Reduction{fem::reduceCached(fem::buildFullModel(tool), fem::defaultReductionDirectory()), tool.fem.youngs_Pa, clamp.value_or(0.0)};
  });
  const std::string weight_key = tool_key + "|" + nlohmann::json(drop.mass_kg).dump() + "|" + nlohmann::json(drop.pan_rows_from_tip_m).dump();
  std::shared_ptr<const WeightSolution> solution;
  std::string solution_key = weight_key;
  if (clamp) {
    const auto ritz = impl_->ritz.get(weight_key, [&] {
      const fem::ReducedModel loaded = loadedModel(reduction->model, panDofs(reduction->model, drop), withoutAddedMass(drop));
      return fem::SpringRitzBasis(loaded, modeCount(loaded));
    });
    solution_key += "|" + nlohmann::json(tool.fem.youngs_Pa).dump() + "|" + nlohmann::json(*clamp).dump();
    solution = impl_->solutions.get(solution_key, [&] { return sprungSolution(*reduction, *ritz, tool, drop); });
  } else {
    solution = impl_->solutions.get(solution_key, [&] { return rigidSolution(*reduction, drop); });
  }
  const double stiffness_scale = clamp ? materialScale(*reduction, tool) : 1.0;  // a rigid basis is at E_ref (integrate scales it)
  const auto basis = impl_->bases.get(solution_key + "|" + nlohmann::json(drop.added_mass_kg).dump(),
                                      [&] { return weightBasis(reduction->model, stiffness_scale, *solution, tool, drop); });
  const auto steps = static_cast<long>(std::llround(drop.duration_s / study.fem.dt_s));
  const double scale = clamp ? 1.0 : tool.fem.youngs_Pa / reduction->E_ref_Pa;  // a sprung basis is at the tool's E
  analysis::Recording rec = integrate(*basis, scale, tool, study.fem.dt_s, steps);
  rec.key = key;
  rec.csv_path = "model run " + key.label();
  return rec;
}

}  // namespace demfem::campaign

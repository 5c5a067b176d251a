// The calibration-weight test (fem/weight_drop.hpp, Section 2.10.1) in the modal basis of the reduced
// model, so that a change of E, alpha or beta costs one scalar recursion per mode (model.hpp).
//
// With Phi the M-normalized modes of (K_r, M_r + weight) on the free DOFs, u = Phi q + u_res. Eq (4)
// keeps the modes uncoupled, and Eq (5) projected on mode j is the scalar three-level recursion
//   q+ (1/dt^2 + c/(2 dt) + w^2/3) = g_bar + q (2/dt^2 - w^2/3) + q- (-1/dt^2 + c/(2 dt) - w^2/3),
// c = alpha w^2 + beta, g_bar the mean of the modal force over the three levels. The load-cell force
// follows Eq (10) on the fixed DOFs, projected on the load-cell sum. The modes kept are the lowest
// kModes; the others answer the step load quasi-statically (static correction u_res = K^-1 f -
// sum_j phi_j g_j / w_j^2, present from the first step), which keeps the static solution exact.
// Scaling: K_r = (E / E_ref) K_r,ref, so w^2, the load-cell stiffness terms and 1/u_res scale by
// E / E_ref while the mode shapes stay.
#include "demfem/campaign/model.hpp"

#include "demfem/fem/model.hpp"
#include "demfem/fem/sensors.hpp"
#include "demfem/fem/weight_drop.hpp"

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

Basis makeBasis(const Reduction& reduction, const study::Tool& tool, const study::WeightDrop& drop) {
  const std::vector<int> pan = panDofs(reduction.model, drop);
  const auto n = static_cast<double>(pan.size());
  Eigen::VectorXd load = Eigen::VectorXd::Zero(reduction.model.dofCount());
  for (int dof : pan) load(dof) = -drop.mass_kg * fem::kStandardGravity_m_s2 / n;  // as fem::simulateWeightDrop
  fem::ReducedModel loaded = reduction.model;
  fem::addLumpedMass(loaded, pan, drop.mass_kg / n);
  const int free_count = static_cast<int>(loaded.freeDofs().size());
  const fem::Modes modes = fem::naturalModes(loaded, std::min(kModes, free_count / 2));
  const fem::Sensors sensors(loaded, tool);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(loaded.dofCount());
  // Load-cell functional c on the reactions (the sensor is linear in them).
  Eigen::VectorXd cell = Eigen::VectorXd::Zero(loaded.dofCount());
  for (int dof : loaded.constraints.fixed_dofs) {
    Eigen::VectorXd unit = zero;
    unit(dof) = 1;
    cell(dof) = sensors.read(zero, unit).load_cell_N;
  }
  const Eigen::RowVectorXd cell_K = cell.transpose() * loaded.K, cell_M = cell.transpose() * loaded.M;
  Basis b;
  const fem::StaticSolution exact = fem::solveStatic(loaded, load);
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

// Eq (5) and (10) per mode for the step load; returns the recording's columns.
analysis::Recording integrate(const Basis& b, double scale, const study::Tool& tool, double dt, long steps) {
  analysis::Recording rec;
  rec.format = analysis::RecordingFormat::Calibrated;
  const auto lead_in = static_cast<long>(std::llround(kLeadIn_s / dt));
  for (long i = 0; i < lead_in; ++i) rec.time_s.push_back(static_cast<double>(i) * dt), rec.force.push_back(0), rec.deformation.push_back(0);
  const double t0 = static_cast<double>(lead_in) * dt;
  const std::size_t modes = b.omega2.size();
  std::vector<double> q(modes, 0.0), q_prev(modes, 0.0);
  std::vector<double> a1(modes), a2(modes), a3(modes), l1(modes), l2(modes), l3(modes);
  const double dt2 = dt * dt;
  for (std::size_t j = 0; j < modes; ++j) {
    const double w2 = scale * b.omega2[j], k = scale * b.cell_stiffness[j], m = b.cell_mass[j];
    const double c = tool.fem.alpha_s * w2 + tool.fem.beta_per_s;          // Eq (4), modal
    const double ck = tool.fem.alpha_s * k + tool.fem.beta_per_s * m;      // c^T C phi_j
    a1[j] = 1 / dt2 + c / (2 * dt) + w2 / 3;                               // Eq (6)
    a2[j] = 2 / dt2 - w2 / 3;                                              // Eq (7)
    a3[j] = -1 / dt2 + c / (2 * dt) - w2 / 3;                              // Eq (8)
    l1[j] = m / dt2 + ck / (2 * dt) + k / 3;
    l2[j] = 2 * m / dt2 - k / 3;
    l3[j] = -m / dt2 + ck / (2 * dt) - k / 3;
  }
  rec.time_s.push_back(t0), rec.force.push_back(0), rec.deformation.push_back(0);
  double cell = 0, cell_prev = 0;  // modal part of the load-cell force at levels i, i-1 (Eq 10)
  const double residual_deformation = b.residual_deformation_mm / scale;
  for (long i = 1; i <= steps; ++i) {
    // Mean modal force of levels i, i-1, i-2: the weight hangs from level 1 on.
    const double levels = static_cast<double>(std::min<long>(i, 3)) / 3;
    double deformation = residual_deformation, cell_sum = 0;
    for (std::size_t j = 0; j < modes; ++j) {
      const double q_next = (levels * b.modal_force[j] + a2[j] * q[j] + a3[j] * q_prev[j]) / a1[j];  // Eq (9)
      cell_sum += l1[j] * q_next - l2[j] * q[j] - l3[j] * q_prev[j];
      q_prev[j] = q[j];
      q[j] = q_next;
      deformation += b.deformation[j] * q_next;
    }
    const double cell_next = 3 * cell_sum - cell - cell_prev;  // Eq (10)
    cell_prev = cell;
    cell = cell_next;
    rec.time_s.push_back(t0 + static_cast<double>(i) * dt);
    rec.force.push_back(cell + b.residual_force_N);
    rec.deformation.push_back(deformation);
  }
  return rec;
}

}  // namespace

struct WeightDropModel::Impl {
  OnceMap<Reduction> reductions;
  OnceMap<Basis> bases;
};

WeightDropModel::WeightDropModel() : impl_(std::make_unique<Impl>()) {}
WeightDropModel::~WeightDropModel() = default;

int WeightDropModel::basesBuilt() const { return impl_->reductions.size() + impl_->bases.size(); }

analysis::Recording WeightDropModel::run(const study::Study& study, const analysis::CaseKey& key, const std::filesystem::path&) {
  if (!study.weight_drop) throw std::invalid_argument("weight-drop model: study '" + study.name + "' has no /weight_drop");
  const study::Tool& tool = fem::deformableTool(study, "");
  const study::WeightDrop& drop = *study.weight_drop;
  const std::string tool_key = reductionKey(tool);
  const auto reduction = impl_->reductions.get(tool_key, [&] {
    return Reduction{fem::reduce(fem::buildFullModel(tool)), tool.fem.youngs_Pa};
  });
  const std::string basis_key = tool_key + "|" + nlohmann::json(drop.mass_kg).dump() + "|" + nlohmann::json(drop.pan_rows_from_tip_m).dump();
  const auto basis = impl_->bases.get(basis_key, [&] { return makeBasis(*reduction, tool, drop); });
  const auto steps = static_cast<long>(std::llround(drop.duration_s / study.fem.dt_s));
  analysis::Recording rec = integrate(*basis, tool.fem.youngs_Pa / reduction->E_ref_Pa, tool, study.fem.dt_s, steps);
  rec.key = key;
  rec.csv_path = "model run " + key.label();
  return rec;
}

}  // namespace demfem::campaign

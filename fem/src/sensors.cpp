#include "demfem/fem/sensors.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>
#include <numbers>
#include <sstream>
#include <stdexcept>
#include <string>

namespace demfem::fem {
namespace {

constexpr double kRowTolerance_m = 1e-9;

// Keypoint rows: distinct y (ascending) and the keypoints on each.
std::vector<std::pair<double, std::vector<int>>> rowsOf(const ReducedModel& model) {
  std::vector<int> order(static_cast<std::size_t>(model.keypointCount()));
  for (std::size_t k = 0; k < order.size(); ++k) order[k] = static_cast<int>(k);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return model.keypoints(a, 1) < model.keypoints(b, 1); });
  std::vector<std::pair<double, std::vector<int>>> rows;
  for (int k : order) {
    const double y = model.keypoints(k, 1);
    if (rows.empty() || y - rows.back().first > kRowTolerance_m) rows.push_back({y, {}});
    rows.back().second.push_back(k);
  }
  return rows;
}

// Adds `scale` times the row mean of u_z to `weights`.
void addRowMean(std::vector<std::pair<int, double>>& weights, const std::vector<int>& row, double scale) {
  for (int k : row) weights.emplace_back(3 * k + 2, scale / static_cast<double>(row.size()));
}

std::vector<int> loadCellZDofs(const ReducedModel& model) {
  std::vector<int> dofs;
  for (int dof : model.constraints.load_cell_dofs)
    if (dof % 3 == 2) dofs.push_back(dof);
  if (dofs.empty()) throw std::invalid_argument("sensors: the model has no load-cell z constraint");
  return dofs;
}

double weighted(const std::vector<std::pair<int, double>>& weights, const Eigen::VectorXd& v) {
  double sum = 0;
  for (const auto& [dof, w] : weights) sum += w * v(dof);
  return sum;
}

}  // namespace

Sensors::Sensors(const ReducedModel& model, const study::Tool& tool)
    : load_cell_z_dofs_(loadCellZDofs(model)), gains_(tool.sensors) {
  const double sensor_from_top_m = tool.constraints.sensor_from_top_m;
  const auto rows = rowsOf(model);
  if (rows.size() < 2) throw std::invalid_argument("sensors: the model needs at least two keypoint rows along y");
  const double top = rows.back().first;
  const double y = top - sensor_from_top_m;
  if (y < rows.front().first - kRowTolerance_m || y > top + kRowTolerance_m)
    throw std::invalid_argument("sensors: the sensor line y = " + std::to_string(y) + " m (sensor_from_top " +
                                std::to_string(sensor_from_top_m) + " m) is outside the tool's keypoints (y in [" +
                                std::to_string(rows.front().first) + ", " + std::to_string(top) + "] m)");
  // Deformation: linear interpolation between the two keypoint rows around the sensor line.
  std::size_t upper = 1;
  while (upper + 1 < rows.size() && rows[upper].first < y - kRowTolerance_m) ++upper;
  const auto& [y0, row0] = rows[upper - 1];
  const auto& [y1, row1] = rows[upper];
  const double t = std::clamp((y - y0) / (y1 - y0), 0.0, 1.0);
  addRowMean(sensor_z_weights_, row0, 1 - t);
  addRowMean(sensor_z_weights_, row1, t);
  // Tip tilt: slope of the row-mean u_z between the lowest two rows.
  const double dy = rows[1].first - rows[0].first;
  addRowMean(tip_slope_weights_, rows[0].second, 1 / dy);
  addRowMean(tip_slope_weights_, rows[1].second, -1 / dy);
}

SensorReadings Sensors::read(const Eigen::VectorXd& displacement, const Eigen::VectorXd& reactions) const {
  SensorReadings s;
  for (int dof : load_cell_z_dofs_) s.load_cell_N += reactions(dof);
  s.deformation_mm = -1000 * weighted(sensor_z_weights_, displacement) * gains_.deformation_gain;
  s.load_cell_N *= gains_.force_gain;
  s.tip_tilt_deg = std::atan(-weighted(tip_slope_weights_, displacement)) * 180 / std::numbers::pi;
  return s;
}

Eigen::VectorXd loadCellInfluence(const ReducedModel& model) {
  const std::vector<int> cell = loadCellZDofs(model);
  Eigen::VectorXd load = Eigen::VectorXd::Zero(model.dofCount());
  for (int dof : cell) load += model.K.col(dof);  // K_fc s on the free DOFs (solveStatic ignores the rest)
  Eigen::VectorXd c = solveStatic(model, load).displacement;  // K_ff^-1 K_fc s, zero at fixed DOFs
  for (int dof : cell) c(dof) = -1;
  return c;
}

std::vector<int> matchKeypoints(const ReducedModel& model, const std::vector<double>& received_xyz, double tolerance_m) {
  const int n = model.keypointCount();
  if (received_xyz.size() != 3 * static_cast<std::size_t>(n))
    throw std::invalid_argument("keypoint matching: the DEM side sent " + std::to_string(received_xyz.size() / 3) +
                                " nodes, the FEM model has " + std::to_string(n) + " keypoints");
  // Bucket the model keypoints on a grid of cell `tolerance` so each lookup checks 27 cells.
  const double cell = std::max(tolerance_m, 1e-12);
  auto key = [&](double x, double y, double z) {
    return std::array<long long, 3>{std::llround(std::floor(x / cell)), std::llround(std::floor(y / cell)),
                                    std::llround(std::floor(z / cell))};
  };
  std::map<std::array<long long, 3>, std::vector<int>> buckets;
  for (int k = 0; k < n; ++k) buckets[key(model.keypoints(k, 0), model.keypoints(k, 1), model.keypoints(k, 2))].push_back(k);
  std::vector<int> result(static_cast<std::size_t>(n), -1);
  std::vector<int> matched_by(static_cast<std::size_t>(n), -1);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d p(received_xyz[3 * i], received_xyz[3 * i + 1], received_xyz[3 * i + 2]);
    const auto c = key(p.x(), p.y(), p.z());
    int best = -1;
    double best_distance = std::numeric_limits<double>::infinity();
    for (long long dx = -1; dx <= 1; ++dx)
      for (long long dy = -1; dy <= 1; ++dy)
        for (long long dz = -1; dz <= 1; ++dz) {
          const auto it = buckets.find({c[0] + dx, c[1] + dy, c[2] + dz});
          if (it == buckets.end()) continue;
          for (int k : it->second) {
            const double d = (model.keypoints.row(k).transpose() - p).norm();
            if (d < best_distance) best_distance = d, best = k;
          }
        }
    if (best < 0 || best_distance > tolerance_m) {
      std::ostringstream s;
      s << "keypoint matching: DEM node " << i << " at (" << p.x() << ", " << p.y() << ", " << p.z()
        << ") m has no FEM keypoint within " << tolerance_m << " m: the DEM tool surface and the FEM model do not "
        << "describe the same keypoints (geometry, spacing or frame differ)";
      throw std::invalid_argument(s.str());
    }
    if (matched_by[static_cast<std::size_t>(best)] >= 0)
      throw std::invalid_argument("keypoint matching: DEM nodes " + std::to_string(matched_by[static_cast<std::size_t>(best)]) +
                                  " and " + std::to_string(i) + " both match FEM keypoint " + std::to_string(best) +
                                  " (duplicate nodes on the DEM side?)");
    matched_by[static_cast<std::size_t>(best)] = i;
    result[static_cast<std::size_t>(i)] = best;
  }
  return result;
}

}  // namespace demfem::fem

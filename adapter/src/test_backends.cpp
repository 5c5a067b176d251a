#include "demfem/adapter/test_backends.hpp"

#include "demfem/adapter/checkpoint_file.hpp"
#include "demfem/adapter/plate_surface.hpp"

#include <cmath>
#include <numbers>

namespace demfem::adapter {

namespace {

enum class LoadKind { Constant, Harmonic, Spring };

struct Geometry {
  std::string name;
  double width_m = 0;
  std::vector<std::array<std::int32_t, 3>> triangles;
  NodeArray undeformed, current;
  std::vector<std::int32_t> tip_nodes;
  RigidMotion motion;
};

class AnalyticBackend final : public CouplingApi {
 public:
  AnalyticBackend(std::string name, LoadKind kind, const std::vector<study::Tool>& tools, const TestLoad& load)
      : name_(std::move(name)), kind_(kind), load_(load) {
    if (!(load.dem_time_step_s > 0))
      throw CouplingError(ErrorCode::BadRequest, "test backend: dem_time_step_s must be > 0");
    for (const auto& tool : tools) {
      if (tool.geometry.kind != study::GeometryKind::Plate)
        throw CouplingError(ErrorCode::Unsupported, "test backend '" + name_ + "': tool '" + tool.name +
                                                        "' is not a plate; only plate tools are supported");
      const auto& g = tool.geometry;
      const PlateSurface surface = makePlateSurface(g.length_m, g.width_m, g.thickness_m, g.keypoint_spacing_m);
      Geometry geo{tool.name, g.width_m, surface.triangles, {}, {}, {}, {}};
      const double band = load.tip_band_m >= 0 ? load.tip_band_m : 0.5 * g.keypoint_spacing_m;
      for (std::size_t i = 0; i < surface.nodes.size(); ++i) {
        for (double c : surface.nodes[i]) geo.undeformed.push_back(c);
        if (surface.nodes[i][1] <= band) geo.tip_nodes.push_back(static_cast<std::int32_t>(i));
      }
      geo.current = geo.undeformed;
      geometries_.push_back(std::move(geo));
    }
  }

  BackendInfo info() override {
    live();
    return {name_, "analytic-1", 1, load_.dem_time_step_s, ""};
  }

  std::vector<GeometryInfo> geometries() override {
    live();
    std::vector<GeometryInfo> list;
    for (const auto& g : geometries_)
      list.push_back({g.name, static_cast<std::int32_t>(g.undeformed.size() / 3), g.triangles});
    return list;
  }

  double time() override {
    live();
    return timeAt(step_);
  }

  NodeArray nodePositions(const std::string& geometry) override { return find(geometry).current; }

  NodeArray nodeForces(const std::string& geometry, ForceMode mode) override {
    const Geometry& g = find(geometry);
    NodeArray forces(g.undeformed.size(), 0.0);
    const bool instantaneous = mode == ForceMode::Instantaneous || interval_start_step_ == step_;
    const double t1 = timeAt(step_), t0 = timeAt(interval_start_step_);
    const double per_node = load_.force_N / static_cast<double>(g.tip_nodes.size());
    const double omega = 2 * std::numbers::pi * load_.frequency_Hz;
    // Harmonic: mean of sin(w t) over [t0, t1] = sin(w tm) sin(w h) / (w h), tm midpoint, h half width.
    const double half = 0.5 * (t1 - t0);
    const double time_factor = instantaneous ? std::sin(omega * t1)
                               : std::sin(omega * (t0 + half)) * (omega * half == 0 ? 1.0 : std::sin(omega * half) / (omega * half));
    for (const std::int32_t node : g.tip_nodes) {
      const std::size_t z = 3 * static_cast<std::size_t>(node) + 2;
      switch (kind_) {
        case LoadKind::Constant:
          forces[z] = per_node;
          break;
        case LoadKind::Harmonic:
          forces[z] = per_node * (1.0 + g.undeformed[z - 2] / g.width_m) * time_factor;
          break;
        case LoadKind::Spring:
          forces[z] = -load_.stiffness_N_m / static_cast<double>(g.tip_nodes.size()) * (g.current[z] - g.undeformed[z]);
          break;
      }
    }
    return forces;
  }

  void setNodePositions(const std::string& geometry, const NodeArray& xyz) override {
    Geometry& g = find(geometry);
    if (xyz.size() != g.undeformed.size())
      throw CouplingError(ErrorCode::SizeMismatch, "setNodePositions('" + geometry + "'): got " +
                                                       std::to_string(xyz.size()) + " values, expected " +
                                                       std::to_string(g.undeformed.size()) + " (n x 3)");
    for (std::size_t i = 0; i < xyz.size(); ++i)
      if (!std::isfinite(xyz[i]))
        throw CouplingError(ErrorCode::BadRequest, "setNodePositions('" + geometry + "'): value " +
                                                       std::to_string(i) + " is not finite");
    g.current = xyz;
  }

  void simulate(double duration_s) override {
    live();
    const std::int64_t steps = demStepCount(duration_s, load_.dem_time_step_s, step_);
    interval_start_step_ = step_;
    step_ += steps;
  }

  RigidMotion rigidMotion(const std::string& geometry) override { return find(geometry).motion; }
  void setRigidMotion(const std::string& geometry, const RigidMotion& motion) override { find(geometry).motion = motion; }

  void checkpoint(const std::filesystem::path& file) override {
    live();
    PayloadWriter out;
    out.put(step_);
    out.put(interval_start_step_);
    out.put(static_cast<std::uint64_t>(geometries_.size()));
    for (const auto& g : geometries_) {
      out.putString(g.name);
      out.putVector(g.current);
      out.put(g.motion);
    }
    writeCheckpointFile(file, checkpointKind(), out.bytes());
  }

  // Everything is read and checked into copies first: a refused file changes nothing.
  void restore(const std::filesystem::path& file) override {
    live();
    const std::string payload = readCheckpointFile(file, checkpointKind());
    PayloadReader in(payload, "checkpoint " + file.string());
    const auto step = in.get<std::int64_t>(), start = in.get<std::int64_t>();
    if (step < 0 || step > kMaxDemSteps || start < 0 || start > step) in.fail("step counts out of range");
    if (in.get<std::uint64_t>() != geometries_.size()) in.fail("geometry count differs from this backend's");
    std::vector<Geometry> restored = geometries_;
    for (auto& g : restored) {
      if (in.getString() != g.name) in.fail("geometry '" + g.name + "' missing");
      auto current = in.getVector<double>();
      if (current.size() != g.undeformed.size()) in.fail("node count of '" + g.name + "' differs");
      for (double c : current)
        if (!std::isfinite(c)) in.fail("a node position of '" + g.name + "' is not finite");
      g.current = std::move(current);
      g.motion = in.get<RigidMotion>();
    }
    in.finish();
    geometries_ = std::move(restored);
    step_ = step;
    interval_start_step_ = start;
  }

  void shutdown() override { shut_down_ = true; }

 private:
  std::string checkpointKind() const { return "test-" + name_; }

  double timeAt(std::int64_t step) const { return static_cast<double>(step) * load_.dem_time_step_s; }

  void live() const {
    if (shut_down_) throw CouplingError(ErrorCode::BadRequest, "test backend '" + name_ + "' has been shut down");
  }

  Geometry& find(const std::string& name) {
    live();
    for (auto& g : geometries_)
      if (g.name == name) return g;
    std::string known;
    for (const auto& g : geometries_) known += (known.empty() ? "'" : ", '") + g.name + "'";
    throw CouplingError(ErrorCode::UnknownGeometry, "unknown geometry '" + name + "' (this backend has " +
                                                        (known.empty() ? "none" : known) + ")");
  }

  std::string name_;
  LoadKind kind_;
  TestLoad load_;
  std::vector<Geometry> geometries_;
  std::int64_t step_ = 0, interval_start_step_ = 0;
  bool shut_down_ = false;
};

}  // namespace

const std::vector<std::string>& testBackendNames() {
  static const std::vector<std::string> names{"constant", "harmonic", "spring"};
  return names;
}

std::unique_ptr<CouplingApi> makeTestBackend(const std::string& kind, const std::vector<study::Tool>& tools,
                                             const TestLoad& load) {
  LoadKind k;
  if (kind == "constant") k = LoadKind::Constant;
  else if (kind == "harmonic") k = LoadKind::Harmonic;
  else if (kind == "spring") k = LoadKind::Spring;
  else throw CouplingError(ErrorCode::Unsupported, "unknown test backend '" + kind + "' (constant, harmonic, spring)");
  return std::make_unique<AnalyticBackend>(kind, k, tools, load);
}

}  // namespace demfem::adapter

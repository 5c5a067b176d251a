// Shared test fixture for the coupled-motion tests of the DEM backends (tests/backends/builtin,
// tests/backends/liggghts): a recorder between the FEM client and the DEM, and the check that the
// tool moves as its plan says (study/tool_motion.hpp).
#pragma once

#include "demfem/adapter/forwarding_api.hpp"
#include "demfem/study/study.hpp"
#include "demfem/study/tool_motion.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace demfem::support {

// Forwards to the backend; at construction and after every simulate() records the tool tip's bin
// height (the rigid motion the DEM moves its mesh by, at its clock) and how far the mesh is from
// where that motion and the positions last set put it (nodePositions() is the mesh minus the rigid
// motion). The first record's motion and clock are kept as `initial` and `initial_time_s`.
class MotionRecorder final : public adapter::ForwardingApi {
 public:
  MotionRecorder(adapter::CouplingApi& dem, std::string tool)
      : ForwardingApi(dem), tool_(std::move(tool)), set_(dem.nodePositions(tool_)) {
    record();
  }
  std::vector<double> heights_m;
  double largest_mesh_offset_m = 0;
  adapter::RigidMotion initial;
  double initial_time_s = -1;

  void setNodePositions(const std::string& g, const adapter::NodeArray& x) override {
    inner().setNodePositions(g, x);
    if (g == tool_) set_ = x;
  }
  void simulate(double duration_s) override {
    inner().simulate(duration_s);
    record();
  }

 private:
  void record() {
    const auto m = inner().rigidMotion(tool_);
    const double t = inner().time();
    if (initial_time_s < 0) initial = m, initial_time_s = t;
    heights_m.push_back(m.origin_m[1] + m.velocity_m_s[1] * (t - m.t0_s));
    const auto xyz = inner().nodePositions(tool_);
    for (std::size_t v = 0; v < xyz.size(); ++v) largest_mesh_offset_m = std::max(largest_mesh_offset_m, std::abs(xyz[v] - set_[v]));
  }
  std::string tool_;
  adapter::NodeArray set_;
};

// The recorded heights of a whole coupled run of `plan`: one per FEM step and the start, never up,
// down to the study's depth (to round-off) at the end of the insertion and held there: the depth is
// reached exactly once, after insertion_steps FEM steps.
inline void checkMovesDownOnceToDepth(const std::vector<double>& heights_m, const study::Study& study, const study::ToolMotionPlan& plan) {
  REQUIRE(heights_m.size() == static_cast<std::size_t>(1 + plan.totalSteps()));
  const double depth_y = study.soil.fill_height_m - study.tools[0].motion.depth_m;
  int arrivals = 0;
  for (std::size_t k = 1; k < heights_m.size(); ++k) {
    INFO("after FEM step " << k);
    CHECK(heights_m[k] <= heights_m[k - 1] + 1e-15);
    if (std::abs(heights_m[k] - depth_y) < 1e-12 && std::abs(heights_m[k - 1] - depth_y) >= 1e-12) {
      ++arrivals;
      CHECK(k == static_cast<std::size_t>(plan.insertion_steps));
    }
  }
  CHECK(arrivals == 1);
  CHECK(heights_m.back() == Approx(depth_y).margin(1e-12));
}

}  // namespace demfem::support

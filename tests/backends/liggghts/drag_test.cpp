// The tool dragged through a deposited soil: draught force and keypoint force bookkeeping.
#include "demfem/backends/liggghts/backend.hpp"
#include "demfem/adapter/tool_drive.hpp"
#include "small_study.hpp"

#include <catch2/catch.hpp>

#include <array>
#include <cmath>

using namespace demfem;

TEST_CASE("a tool dragged through deposited soil feels a draught force its keypoints account for", "[liggghts]") {
  auto study = liggghts::testing::smallStudy();
  auto backend = liggghts::makeBackend(study);
  REQUIRE(backend->time() == 0.0);
  const auto start = backend->nodePositions("tool");
  adapter::insertAndStartDrag(*backend, study, study.tools[0]);
  const double drag_start = backend->time();
  const auto motion = backend->rigidMotion("tool");
  const double interval = 0.01;
  double draught_sum = 0;
  const int intervals = 8;
  for (int i = 0; i < intervals; ++i) {
    backend->simulate(interval);
    const auto last = backend->nodeForces("tool", adapter::ForceMode::Instantaneous);
    const auto mean = backend->nodeForces("tool", adapter::ForceMode::IntervalMean);
    std::array<double, 3> last_total{}, mean_total{};
    for (std::size_t k = 0; k < last.size() / 3; ++k)
      for (std::size_t c = 0; c < 3; ++c) {
        last_total[c] += last[3 * k + c];
        mean_total[c] += mean[3 * k + c];
      }
    const auto mesh_total = liggghts::meshTotalForce(*backend, "tool");
    // The keypoint split conserves every contact force LIGGGHTS' stress mesh sums (round-off only).
    for (std::size_t c = 0; c < 3; ++c)
      CHECK(last_total[c] == Approx(mesh_total[c]).epsilon(1e-9).margin(1e-9));
    draught_sum += -mean_total[2];
  }
  // Each simulate() runs round(interval / dt) whole DEM steps (coupling_api.hpp).
  const double dt = backend->info().dem_time_step_s;
  const double reached = intervals * std::round(interval / dt) * dt;
  CHECK(backend->time() - drag_start == Approx(reached).epsilon(1e-9));
  // The soil resists the motion: a positive mean draught force (force on the tool along -z).
  CHECK(draught_sum / intervals > 0.01);
  // Keypoints in the local frame do not move with the rigid motion.
  const auto after = backend->nodePositions("tool");
  for (std::size_t v = 0; v < after.size(); ++v) REQUIRE(after[v] == Approx(start[v]).margin(1e-9));
  // The tool moved along the bin by v t: its rigid motion says so.
  const auto m = backend->rigidMotion("tool");
  CHECK(m.origin_m[2] + m.velocity_m_s[2] * (backend->time() - m.t0_s) ==
        Approx(motion.origin_m[2] + study.tools[0].motion.velocity_m_s * reached).epsilon(1e-9));
  // Inserted to depth within the half DEM step that rounding the insertion to whole steps leaves.
  CHECK(m.origin_m[1] == Approx(study.soil.fill_height_m - study.tools[0].motion.depth_m)
                             .margin(0.5 * study.tools[0].motion.insertion_velocity_m_s * dt + 1e-12));
}

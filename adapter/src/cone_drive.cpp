#include "demfem/adapter/cone_drive.hpp"

#include "demfem/adapter/tool_drive.hpp"
#include "demfem/study/tool_motion.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <stdexcept>

namespace demfem::adapter {

double settledSurface(const BackendInfo& info, const study::Study& study) {
  if (info.soil_json.empty()) return study.soil.fill_height_m;
  const auto record = nlohmann::json::parse(info.soil_json);
  return record.at("surface_height_mm").get<double>() * 1e-3;
}

std::vector<ConeRecord> pushCones(CouplingApi& dem, const study::Study& study, const ConeProgress& progress) {
  if (study.kind != study::StudyKind::ConePenetration)
    throw std::invalid_argument("study '" + study.name + "': pushing cones needs a cone-penetration study");
  const ForceMode mode = study.coupling.force_averaging == study::ForceAveraging::Instantaneous ? ForceMode::Instantaneous
                                                                                                : ForceMode::IntervalMean;
  std::vector<study::ToolMotionPlan> plans;
  std::vector<ConeRecord> records;
  std::int64_t steps = 0;
  const double plan_start = dem.time();
  const double surface = settledSurface(dem.info(), study);
  for (const auto& tool : study.tools) {
    plans.push_back(study::planToolMotion(study, tool));
    records.push_back({tool.name, tool.geometry.cone_area_m2, {}, {}, {}});
    steps = std::max(steps, plans.back().insertion_steps);
    dem.setRigidMotion(tool.name, rigidMotionOf(plans.back().insertion, plan_start));
  }
  const double dt = study.fem.dt_s;
  for (std::int64_t step = 0; step < steps; ++step) {
    for (std::size_t c = 0; c < plans.size(); ++c)
      if (step == plans[c].insertion_steps) dem.setRigidMotion(records[c].name, rigidMotionOf(plans[c].drag, plan_start));
    dem.simulate(dt);
    const double t = static_cast<double>(step + 1) * dt;
    for (std::size_t c = 0; c < plans.size(); ++c) {
      const NodeArray f = dem.nodeForces(records[c].name, mode);
      double fy = 0;
      for (std::size_t k = 1; k < f.size(); k += 3) fy += f[k];
      records[c].time_s.push_back(t);
      records[c].tip_depth_m.push_back(surface - plans[c].positionAt(t)[1]);
      records[c].force_N.push_back(fy);
    }
    if (progress) progress(step + 1, steps);
  }
  return records;
}

}  // namespace demfem::adapter

#include "demfem/campaign/calibration.hpp"

#include <algorithm>
#include <map>
#include <set>
#include <sstream>

namespace demfem::campaign {
namespace {

std::string kindOf(const nlohmann::ordered_json& study) { return study.value("kind", std::string()); }

int firstDeformableTool(const nlohmann::ordered_json& study) {
  const auto& tools = study.at("tools");
  for (std::size_t i = 0; i < tools.size(); ++i)
    if (tools[i].value("fem", nlohmann::ordered_json::object()).value("deformable", true)) return static_cast<int>(i);
  throw ArgumentError("--preset weight-drop: the study has no deformable tool");
}

// Index of the particle-particle interaction of `material` in /soil/interactions.
int selfInteraction(const nlohmann::ordered_json& study, const std::string& material) {
  const auto& table = study.at("/soil/interactions"_json_pointer);
  for (std::size_t i = 0; i < table.size(); ++i) {
    const auto& m = table[i].at("materials");
    if (m.size() == 2 && m[0] == material && m[1] == material) return static_cast<int>(i);
  }
  throw ArgumentError("--preset layered-soil: /soil/interactions has no entry for the pair [" + material + ", " + material + "]");
}

ParameterSpec spec(const std::string& pointer, double lo, double hi, bool log) { return {pointer, lo, hi, log, pointer}; }

}  // namespace

std::vector<Stage> weightDropPreset(const nlohmann::ordered_json& study, const std::vector<analysis::Recording>& recordings) {
  if (kindOf(study) != "weight-drop") throw ArgumentError("--preset weight-drop: the study is of kind '" + kindOf(study) + "', not weight-drop");
  Stage stage;
  stage.title = "E and Rayleigh alpha from the calibration weights (Section 2.10.1)";
  std::set<analysis::CaseKey> cases;
  for (const auto& r : recordings)
    if (r.key.kind == analysis::CaseKind::CalibrationWeight) cases.insert(r.key);
  if (cases.empty()) throw ArgumentError("--preset weight-drop: none of the recordings is a calibration-weight run (sidecar mass_kg)");
  stage.cases.assign(cases.begin(), cases.end());
  const std::string tool = "/tools/" + std::to_string(firstDeformableTool(study)) + "/fem/";
  const double E = study.at(nlohmann::ordered_json::json_pointer(tool + "E_Pa")).get<double>();
  stage.parameters = {spec(tool + "E_Pa", E / 4, E * 4, true), spec(tool + "alpha_s", 1e-6, 1e-2, true)};
  return {stage};
}

std::vector<Stage> layeredSoilPreset(const nlohmann::ordered_json& study, const std::string& origin,
                                     const std::vector<analysis::Recording>& recordings) {
  const std::string kind = kindOf(study);
  if (kind != "coupled" && kind != "dem-only")
    throw ArgumentError("--preset layered-soil: the study is of kind '" + kind + "', not coupled or dem-only");
  const study::Study parsed = study::parseStudy(study.dump(), origin);
  std::map<double, std::vector<analysis::CaseKey>> by_depth;
  for (const auto& r : recordings)
    if (r.key.kind == analysis::CaseKind::SoilBin) {
      auto& keys = by_depth[r.key.depth_mm];
      if (std::find(keys.begin(), keys.end(), r.key) == keys.end()) keys.push_back(r.key);
    }
  if (by_depth.empty()) throw ArgumentError("--preset layered-soil: none of the recordings is a soil-bin run (sidecar depth_mm)");
  const bool rolling = parsed.soil.contact.rolling != study::RollingModel::None;
  std::set<std::string> fitted;
  std::vector<Stage> stages;
  for (const auto& [depth_mm, keys] : by_depth) {
    // Section 2.10.2: the deepest layer the tool tip reaches at this depth.
    const study::Layer* reached = nullptr;
    for (const auto& layer : parsed.soil.layers)
      if (layer.top_depth_m * 1000 < depth_mm) reached = &layer;
    if (!reached || !fitted.insert(reached->material).second) continue;
    const std::string base = "/soil/interactions/" + std::to_string(selfInteraction(study, reached->material)) + "/";
    Stage stage;
    std::ostringstream title;
    title << "depth " << depth_mm << " mm: friction of " << reached->material;
    stage.title = title.str();
    stage.cases = keys;
    stage.parameters.push_back(spec(base + "static_friction", 0.05, 1.5, false));
    if (rolling) stage.parameters.push_back(spec(base + "rolling_friction", 0.0, 0.5, false));
    stages.push_back(stage);
  }
  return stages;
}

}  // namespace demfem::campaign

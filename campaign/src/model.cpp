#include "demfem/campaign/model.hpp"

#include "demfem/backends/builtin/backend.hpp"
#include "demfem/campaign/parameters.hpp"
#include "demfem/fem/coupled_driver.hpp"

#include <cmath>

namespace demfem::campaign {
namespace {

std::string kindName(const nlohmann::ordered_json& study_json) {
  return study_json.contains("kind") && study_json["kind"].is_string() ? study_json["kind"].get<std::string>() : "coupled";
}

}  // namespace

study::Study caseStudy(const nlohmann::ordered_json& study_json, const std::string& origin, const analysis::CaseKey& key) {
  nlohmann::ordered_json derived = study_json;
  const std::string kind = kindName(study_json);
  switch (key.kind) {
    case analysis::CaseKind::CalibrationWeight:
      if (kind != "weight-drop")
        throw ArgumentError("recording case '" + key.title() + "': a calibration-weight case needs a weight-drop study, " + origin +
                            " is of kind " + kind);
      derived["weight_drop"]["mass_kg"] = key.mass_kg;
      break;
    case analysis::CaseKind::SoilBin:
      if (kind != "coupled" && kind != "dem-only")
        throw ArgumentError("recording case '" + key.title() + "': a soil-bin case needs a coupled or dem-only study, " + origin +
                            " is of kind " + kind);
      derived["tools"][0]["motion"]["depth_mm"] = key.depth_mm;
      break;
  }
  return study::parseStudy(derived.dump(), origin);
}

analysis::CaseKey studyCase(const study::Study& study) {
  analysis::CaseKey key;
  key.tool = study.tools.empty() ? std::string("tool") : study.tools.front().name;
  if (study.weight_drop && study.kind == study::StudyKind::WeightDrop) {
    key.kind = analysis::CaseKind::CalibrationWeight;
    key.mass_kg = std::round(study.weight_drop->mass_kg * 1e6) / 1e6;
  } else {
    key.kind = analysis::CaseKind::SoilBin;
    key.depth_mm = std::round(study.tools.front().motion.depth_m * 1e9) / 1e6;
  }
  return key;
}

analysis::Recording SoilBinModel::run(const study::Study& study, const analysis::CaseKey& key, const std::filesystem::path& scratch) {
  fem::CoupledRunOptions options;
  options.output_dir = scratch;
  fem::CoupledDriver driver(study, options);
  const std::unique_ptr<adapter::CouplingApi> dem = builtin::makeBackend(study);
  driver.run(*dem);
  analysis::Recording recording = analysis::readRecording(scratch / "sensors.csv");
  recording.key = key;
  return recording;
}

std::unique_ptr<Model> makeModel(const study::Study& study) {
  switch (study.kind) {
    case study::StudyKind::WeightDrop:
      return std::make_unique<WeightDropModel>();
    case study::StudyKind::Coupled:
    case study::StudyKind::DemOnly:
      return std::make_unique<SoilBinModel>();
    case study::StudyKind::ConePenetration:
    case study::StudyKind::FemOnly:
      break;
  }
  throw ArgumentError("study '" + study.name + "': calibrate runs weight-drop, coupled and dem-only studies only");
}

}  // namespace demfem::campaign

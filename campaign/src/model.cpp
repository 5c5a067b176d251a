#include "demfem/campaign/model.hpp"

#include "demfem/adapter/settled_soil.hpp"
#include "demfem/adapter/tool_drive.hpp"
#include "demfem/backends/builtin/backend.hpp"
#include "demfem/backends/builtin/soil_bin.hpp"
#include "demfem/campaign/parameters.hpp"
#include "demfem/fem/coupled_driver.hpp"
#include "demfem/fem/reduction_cache.hpp"
#include "demfem/study/tool_motion.hpp"

#include <cmath>
#include <set>

namespace demfem::campaign {
namespace {

std::string kindName(const nlohmann::ordered_json& study_json) {
  return study_json.contains("kind") && study_json["kind"].is_string() ? study_json["kind"].get<std::string>() : "coupled";
}

}  // namespace

study::Study caseStudy(const nlohmann::ordered_json& study_json, const std::string& origin, const analysis::CaseKey& key,
                       std::optional<double> stroke_end_mm) {
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
      if (stroke_end_mm && study::parseStudy(derived.dump(), origin).tools.front().motion.stroke_m * 1000 > *stroke_end_mm)
        derived["tools"][0]["motion"]["stroke_mm"] = *stroke_end_mm;
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

namespace {

// The coupled run's sensors.csv (force_N = the load cell).
analysis::Recording loadCellRun(const study::Study& study, const std::filesystem::path& scratch) {
  fem::CoupledRunOptions options;
  options.output_dir = scratch;
  options.reduction_cache_dir = fem::defaultReductionDirectory();
  fem::CoupledDriver driver(study, options);
  const std::unique_ptr<adapter::CouplingApi> dem = builtin::makeBackend(study);
  driver.run(*dem);
  return analysis::readRecording(scratch / "sensors.csv");
}

// The rigid tool driven through its plan by the DEM alone; force_N = the draught per FEM step.
analysis::Recording draughtRun(const study::Study& study) {
  const study::Tool& tool = study.tools.front();
  if (study.kind != study::StudyKind::DemOnly && tool.fem.deformable)
    throw ArgumentError("--soil-force draught: tool '" + tool.name + "' is deformable; the draught is the force on a rigid tool (a dem-only study)");
  const study::ToolMotionPlan plan = study::planToolMotion(study, tool);
  const std::unique_ptr<adapter::CouplingApi> dem = builtin::makeBackend(study);
  adapter::insertAndStartDrag(*dem, study, tool);
  analysis::Recording r;
  r.format = analysis::RecordingFormat::Calibrated;
  const double speed_mm_s = std::hypot(plan.drag.velocity_m_s[0], plan.drag.velocity_m_s[1], plan.drag.velocity_m_s[2]) * 1000;
  for (std::int64_t k = 1; k <= plan.drag_steps; ++k) {
    dem->simulate(plan.dt_s);
    double draught_N = 0;
    adapter::accumulateDraught(draught_N, dem->nodeForces(tool.name, adapter::ForceMode::IntervalMean));
    const double t_s = static_cast<double>(k) * plan.dt_s;
    r.time_s.push_back(t_s);
    r.force.push_back(draught_N);
    r.deformation.push_back(0.0);
    r.displacement_mm.push_back(speed_mm_s * t_s);
    r.line.push_back(static_cast<std::size_t>(k) + 1);
  }
  return r;
}

}  // namespace

analysis::Recording SoilBinModel::run(const study::Study& study, const analysis::CaseKey& key, const std::filesystem::path& scratch) {
  prepareSoil(study, {});  // normally made by prepare() already
  study::Study run_study = study;
  run_study.output.directory = scratch;  // the DEM's files (output.vtk_every > 0) in this run's directory, not a shared one
  analysis::Recording recording;
  switch (force_) {
    case SoilForce::LoadCell: recording = loadCellRun(run_study, scratch); break;
    case SoilForce::Draught: recording = draughtRun(run_study); break;
  }
  recording.key = key;
  return recording;
}

std::string SoilBinModel::name() const {
  const std::string packing = packing_ ? "-packing-" + study::soilHash(*packing_) : "";
  switch (force_) {
    case SoilForce::LoadCell: return "coupled-builtin-1" + packing;
    case SoilForce::Draught: return "dem-draught-builtin-1" + packing;
  }
  return {};
}

namespace {

// Deposits the soil of `s`, its progress reported as that of the study named `reported_as`.
void deposit(const study::Study& s, const std::string& reported_as, const DepositionProgress& on_deposit) {
  builtin::ensureSettledSoil(s, [&](double fraction, const std::string& stage_line) {
    if (on_deposit) on_deposit(reported_as, fraction, stage_line);
  });
}

}  // namespace

void SoilBinModel::prepare(const std::vector<study::Study>& case_studies, const DepositionProgress& on_deposit) {
  std::set<std::string> done;
  for (const study::Study& s : case_studies)
    if (done.insert(study::soilHash(s)).second) prepareSoil(s, on_deposit);
}

void SoilBinModel::prepareSoil(const study::Study& s, const DepositionProgress& on_deposit) const {
  const auto file = adapter::settledSoilFile(s, adapter::defaultSoilDirectory());
  if (!std::filesystem::exists(file)) {
    if (packing_)
      relabelPacking(s, file, on_deposit);
    else
      deposit(s, s.name, on_deposit);
  }
  const std::string message = adapter::unsettledSoilMessage(file, adapter::readSettledSoil(file, s).settling);
  if (!message.empty() && !allow_unsettled_soil_) throw ArgumentError("study '" + s.name + "': " + message);
}

void SoilBinModel::relabelPacking(const study::Study& s, const std::filesystem::path& file, const DepositionProgress& on_deposit) const {
  const auto dir = adapter::defaultSoilDirectory();
  study::Study reference = *packing_;
  reference.soil.deposition_seed = s.soil.deposition_seed;
  const auto& a = reference.soil;
  const auto& b = s.soil;
  if (a.bin_length_m != b.bin_length_m || a.bin_width_m != b.bin_width_m || a.fill_height_m != b.fill_height_m ||
      a.diameter_min_m != b.diameter_min_m || a.diameter_max_m != b.diameter_max_m)
    throw ArgumentError("shared soil packing: study '" + s.name + "' changes the bin, fill height or particle sizes of '" + reference.name +
                        "', whose deposition it would reuse");
  const auto reference_file = adapter::settledSoilFile(reference, dir);
  // Reported under the name of the study the packing is for: the packing study's own name is the
  // same for every seed.
  if (!std::filesystem::exists(reference_file)) deposit(reference, s.name, on_deposit);
  adapter::SettledSoil soil = adapter::readSettledSoil(reference_file, reference);
  soil.soil_hash = study::soilHash(s);
  for (auto& p : soil.particles) p.layer = builtin::layerAt(s.soil, p.x_m[1]);
  adapter::writeSettledSoil(file, soil);
}

std::unique_ptr<Model> makeModel(const study::Study& study, SoilForce soil_force, bool shared_packing, bool allow_unsettled_soil) {
  switch (study.kind) {
    case study::StudyKind::WeightDrop:
      return std::make_unique<WeightDropModel>();
    case study::StudyKind::Coupled:
    case study::StudyKind::DemOnly:
      return std::make_unique<SoilBinModel>(soil_force, shared_packing ? std::optional(study) : std::nullopt, allow_unsettled_soil);
    case study::StudyKind::ConePenetration:
    case study::StudyKind::FemOnly:
      break;
  }
  throw ArgumentError("study '" + study.name + "': calibrate runs weight-drop, coupled and dem-only studies only");
}

}  // namespace demfem::campaign

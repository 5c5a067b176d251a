// demfem-fem weight-drop: the calibration-weight test of Section 2.10.1 (Fig. 5, 7, 8) from a study
// file of kind weight-drop: a calibrated recording (CSV t_s,force_N,deformation_mm + its JSON
// sidecar, docs/analysis.md) that `demfem evaluate` / `compare` take as it is, and the steady value,
// frequency and damping ratio fitted to the whole record (analysis/include/demfem/analysis/step_fit.hpp).
#include "demfem/adapter/output_files.hpp"
#include "demfem/analysis/step_fit.hpp"
#include "demfem/cli/cli_support.hpp"
#include "demfem/cli/progress.hpp"
#include "demfem/fem/model.hpp"
#include "demfem/fem/weight_drop.hpp"
#include "reduction.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>

namespace demfem::cli {

namespace {

namespace fs = std::filesystem;

// Writes what `text` prints to `path` atomically and checked (adapter/output_files.hpp).
void writeFileAtomically(const fs::path& path, const std::function<void(std::ostream&)>& text) {
  std::ostringstream out;
  text(out);
  adapter::writeFileAtomically(path, out.str());
}

nlohmann::json fitJson(const analysis::StepResponseFit& fit, const std::string& unit) {
  return {{"steady_" + unit, fit.steady},
          {"steady_error_" + unit, fit.steady_error},
          {"frequency_Hz", fit.frequency_Hz},
          {"frequency_error_Hz", fit.frequency_error_Hz},
          {"damping_ratio", fit.damping_ratio},
          {"damping_ratio_error", fit.damping_ratio_error},
          {"residual_rms_" + unit, fit.residual_rms}};
}

}  // namespace

void addFemWeightDropCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("weight-drop",
                                 "Calibration-weight test (Section 2.10.1): recording like Fig. 7 (CSV + sidecar), fitted figures like Fig. 8");
  auto study_file = std::make_shared<std::string>();
  auto csv_file = std::make_shared<std::string>();
  auto mass = std::make_shared<double>(0);
  auto quiet = std::make_shared<bool>(false);
  cmd->add_option("study", *study_file, "study file of kind weight-drop (JSON)")->required()->check(CLI::ExistingFile);
  cmd->add_option("--csv", *csv_file, "CSV output (default: <output.directory>/<study name>.csv); the sidecar is the same stem .json");
  cmd->add_option("--mass-kg", *mass, "override the study's weight (kg)")->check(CLI::PositiveNumber);
  cmd->add_flag("--quiet", *quiet, "No progress output");
  std::string& json_target = addJsonOption(*cmd);
  cmd->callback([=, &json_target] {
    const study::Study study = study::loadStudy(*study_file);
    if (!study.weight_drop) throw InputError(*study_file + ": /weight_drop is missing: not a weight-drop study");
    study::WeightDrop drop = *study.weight_drop;
    if (*mass > 0) drop.mass_kg = *mass;
    const fs::path csv = csv_file->empty() ? study.output.directory / (study.name + ".csv") : fs::path(*csv_file);
    if (csv.extension() != ".csv") throw InputError("--csv " + csv.string() + ": must end in .csv (its sidecar is the same stem .json)");
    const fs::path sidecar = fs::path(csv).replace_extension(".json");
    if (!json_target.empty() && json_target != "-" && fs::weakly_canonical(json_target) == fs::weakly_canonical(sidecar))
      throw InputError("--json " + json_target + " is the recording's sidecar; choose another file");
    const study::Tool& tool = fem::deformableTool(study, "");

    const fem::ReducedModel model = reduceWithProgress(fem::buildFullModel(tool), !*quiet);
    Progress run("weight drop", !*quiet);
    const fem::WeightDropResult result =
        fem::simulateWeightDrop(model, tool, drop, study.fem.dt_s, [&run](double fraction) { run.update(fraction); });
    run.finish(std::to_string(result.samples.size()) + " samples");

    std::vector<double> t, force, deformation;
    for (const auto& s : result.samples) {
      t.push_back(s.t_s);
      force.push_back(s.force_N);
      deformation.push_back(s.deformation_mm);
    }
    const analysis::StepResponseFit force_fit = analysis::fitStepResponse(t, force, csv.string() + ": column 'force_N'");
    const analysis::StepResponseFit deformation_fit = analysis::fitStepResponse(t, deformation, csv.string() + ": column 'deformation_mm'");

    if (csv.has_parent_path()) fs::create_directories(csv.parent_path());
    writeFileAtomically(csv, [&](std::ostream& out) { fem::writeWeightDropCsv(out, result); });
    const nlohmann::json recording_sidecar{{"tool", tool.name},
                                           {"mass_kg", drop.mass_kg},
                                           {"repeat", 1},
                                           {"complete", true},
                                           {"sample_rate_hz", 1.0 / study.fem.dt_s},
                                           {"study", study.name}};
    writeFileAtomically(sidecar, [&](std::ostream& out) { out << recording_sidecar.dump(2) << '\n'; });

    if (textOnStdout(json_target)) {
      std::printf("weight %.3f kg on %d pan keypoints, %zu samples -> %s (+ %s)\n", drop.mass_kg, result.pan_keypoints,
                  result.samples.size(), csv.string().c_str(), sidecar.filename().string().c_str());
      std::printf("%-12s %14s %14s %12s %14s %12s\n", "signal", "steady", "static", "freq_Hz", "damping_ratio", "residual");
      std::printf("%-12s %14.6f %14.6f %12.4f %14.5f %12.3g\n", "force_N", force_fit.steady, result.static_force_N,
                  force_fit.frequency_Hz, force_fit.damping_ratio, force_fit.residual_rms);
      std::printf("%-12s %14.6f %14.6f %12.4f %14.5f %12.3g\n", "deform_mm", deformation_fit.steady, result.static_deformation_mm,
                  deformation_fit.frequency_Hz, deformation_fit.damping_ratio, deformation_fit.residual_rms);
    }
    writeJson(json_target, {{"study", study.name},
                            {"tool", tool.name},
                            {"mass_kg", drop.mass_kg},
                            {"pan_keypoints", result.pan_keypoints},
                            {"dt_s", study.fem.dt_s},
                            {"csv", csv.string()},
                            {"sidecar", sidecar.string()},
                            {"force", fitJson(force_fit, "N")},
                            {"deformation", fitJson(deformation_fit, "mm")},
                            {"static_force_N", result.static_force_N},
                            {"static_deformation_mm", result.static_deformation_mm}});
  });
}

}  // namespace demfem::cli

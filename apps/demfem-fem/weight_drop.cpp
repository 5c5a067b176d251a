// demfem-fem weight-drop: the calibration-weight test of Section 2.10.1 (Fig. 5, 7, 8) from a study
// file of kind weight-drop: CSV t_s,force_N,deformation_mm and steady value, frequency, damping.
#include "demfem/cli/cli_support.hpp"
#include "demfem/fem/model.hpp"
#include "demfem/fem/weight_drop.hpp"

#include <cstdio>
#include <filesystem>
#include <fstream>

namespace demfem::cli {

void addFemWeightDropCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("weight-drop", "Calibration-weight test (Section 2.10.1): CSV like Fig. 7, characteristics like Fig. 8");
  auto study_file = std::make_shared<std::string>();
  auto csv_file = std::make_shared<std::string>();
  auto mass = std::make_shared<double>(0);
  cmd->add_option("study", *study_file, "study file of kind weight-drop (JSON)")->required()->check(CLI::ExistingFile);
  cmd->add_option("--csv", *csv_file, "CSV output (default: <output.directory>/<study name>.csv)");
  cmd->add_option("--mass-kg", *mass, "override the study's weight (kg)")->check(CLI::PositiveNumber);
  std::string& json_target = addJsonOption(*cmd);
  cmd->callback([=, &json_target] {
    const study::Study study = study::loadStudy(*study_file);
    if (!study.weight_drop) throw InputError(*study_file + ": /weight_drop is missing: not a weight-drop study");
    study::WeightDrop drop = *study.weight_drop;
    if (*mass > 0) drop.mass_kg = *mass;
    const study::Tool& tool = fem::deformableTool(study, "");
    const fem::ReducedModel model = fem::reduce(fem::buildFullModel(tool));
    const fem::WeightDropResult result = fem::simulateWeightDrop(model, tool, drop, study.fem.dt_s);
    const std::filesystem::path csv = csv_file->empty() ? study.output.directory / (study.name + ".csv") : std::filesystem::path(*csv_file);
    if (csv.has_parent_path()) std::filesystem::create_directories(csv.parent_path());
    std::ofstream out(csv);
    if (!out) throw std::runtime_error("cannot write " + csv.string());
    fem::writeWeightDropCsv(out, result);
    if (!out) throw std::runtime_error("writing " + csv.string() + " failed");
    std::printf("weight %.3f kg on %d pan keypoints, %zu samples -> %s\n", drop.mass_kg, result.pan_keypoints,
                result.samples.size(), csv.string().c_str());
    std::printf("%-12s %14s %14s %12s %14s\n", "signal", "steady", "static", "freq_Hz", "damping_ratio");
    std::printf("%-12s %14.6f %14.6f %12.4f %14.5f\n", "force_N", result.force.steady, result.static_force_N,
                result.force.frequency_Hz, result.force.damping_ratio);
    std::printf("%-12s %14.6f %14.6f %12.4f %14.5f\n", "deform_mm", result.deformation.steady, result.static_deformation_mm,
                result.deformation.frequency_Hz, result.deformation.damping_ratio);
    auto characteristics = [](const fem::SignalCharacteristics& c, const char* unit_key) {
      return nlohmann::json{{unit_key, c.steady}, {"frequency_Hz", c.frequency_Hz}, {"damping_ratio", c.damping_ratio}, {"maxima", c.maxima}};
    };
    writeJson(json_target, {{"study", study.name},
                            {"mass_kg", drop.mass_kg},
                            {"pan_keypoints", result.pan_keypoints},
                            {"dt_s", study.fem.dt_s},
                            {"csv", csv.string()},
                            {"force", characteristics(result.force, "steady_N")},
                            {"deformation", characteristics(result.deformation, "steady_mm")},
                            {"static_force_N", result.static_force_N},
                            {"static_deformation_mm", result.static_deformation_mm}});
  });
}

}  // namespace demfem::cli

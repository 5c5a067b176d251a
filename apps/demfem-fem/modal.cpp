// demfem-fem modal: first natural frequencies of a study's tool, full model and keypoint-reduced.
#include "demfem/cli/cli_support.hpp"
#include "demfem/fem/model.hpp"
#include "reduction.hpp"

#include <cstdio>

namespace demfem::cli {

void addFemModalCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("modal", "First natural frequencies of the full and the reduced (Eq 11-15) tool model");
  auto study_file = std::make_shared<std::string>();
  auto tool_name = std::make_shared<std::string>();
  auto count = std::make_shared<int>(6);
  auto full_integration = std::make_shared<bool>(false);
  auto quiet = std::make_shared<bool>(false);
  cmd->add_option("study", *study_file, "study file (JSON)")->required()->check(CLI::ExistingFile);
  cmd->add_option("--tool", *tool_name, "tool name (default: the first deformable tool)");
  cmd->add_option("-n,--modes", *count, "number of modes")->check(CLI::Range(1, 50));
  cmd->add_flag("--full-integration", *full_integration, "3x3x3 Gauss stiffness (C3D20) instead of 2x2x2 (C3D20R)");
  cmd->add_flag("--quiet", *quiet, "No progress output");
  std::string& json_target = addJsonOption(*cmd);
  cmd->callback([=, &json_target] {
    const study::Study study = study::loadStudy(*study_file);
    const study::Tool& tool = fem::deformableTool(study, *tool_name);
    const fem::FullModel full = fem::buildFullModel(tool, *full_integration ? fem::HexIntegration::Full : fem::HexIntegration::Reduced);
    const fem::ReducedModel reduced = reduceWithProgress(full, !*quiet);
    const bool text = textOnStdout(json_target);
    const fem::Modes full_modes = fem::naturalModes(full, *count);
    const fem::Modes reduced_modes = fem::naturalModes(reduced, *count);
    if (text) std::printf("tool %s: %d keypoints, %d full DOFs, %d reduced DOFs\n", tool.name.c_str(), reduced.keypointCount(),
                full.dofCount(), reduced.dofCount());
    if (text) std::printf("%5s %14s %14s %12s\n", "mode", "full_Hz", "reduced_Hz", "diff_%");
    nlohmann::json modes = nlohmann::json::array();
    for (int m = 0; m < *count; ++m) {
      const double f = full_modes.frequencies_Hz[m], r = reduced_modes.frequencies_Hz[m];
      if (text) std::printf("%5d %14.4f %14.4f %12.5f\n", m + 1, f, r, 100 * (r / f - 1));
      modes.push_back({{"mode", m + 1}, {"full_Hz", f}, {"reduced_Hz", r}, {"difference_percent", 100 * (r / f - 1)}});
    }
    writeJson(json_target, {{"study", study.name},
                            {"tool", tool.name},
                            {"keypoints", reduced.keypointCount()},
                            {"full_dofs", full.dofCount()},
                            {"reduced_dofs", reduced.dofCount()},
                            {"modes", modes}});
  });
}

}  // namespace demfem::cli

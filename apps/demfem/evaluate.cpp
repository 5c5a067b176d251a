// demfem evaluate: paper Section 2.3 on soil-bin recordings, step-response figures of
// calibration-weight recordings; tables, evaluated curves, plots and a report (docs/analysis.md).
#include "analysis_options.hpp"
#include "commands.hpp"

#include <iostream>

namespace demfem::cli {

void addEvaluateCommand(CLI::App& app) {
  struct Options {
    AnalysisOptions analysis;
    std::vector<std::string> inputs;
  };
  auto options = std::make_shared<Options>();
  const AnalysisCommand command = addAnalysisCommand(app, "evaluate",
      "Evaluate soil-bin and calibration-weight recordings (paper Section 2.3): RUN.csv with a sidecar RUN.json, "
      "or directories of them; repeats of one case (tool + depth_mm or mass_kg) are pooled",
      options->analysis, "evaluation");
  CLI::App* cmd = command.cmd;
  cmd->add_option("recordings", options->inputs, "Recordings (CSV + JSON sidecar of the same stem) or directories holding them")->required();
  std::string& json_target = *command.json_target;
  cmd->callback([options, &json_target] {
    runAnalysis([&] {
      finishAnalysisOptions(options->analysis);
      const OutputClaim claim(options->analysis.out_dir);
      const auto& settings = options->analysis.settings;
      const std::vector<std::filesystem::path> paths(options->inputs.begin(), options->inputs.end());
      const auto recordings = analysis::readRecordings(paths);
      const auto result = analysis::evaluate(recordings, settings);

      const auto dir = writeStaged(options->analysis, [&](analysis::StagedOutput& out, const analysis::GnuplotRenderer* renderer) {
        analysis::writeEvaluation(result, settings, out, renderer);
      });
      writeJson(json_target, analysis::toJson(result, settings));

      if (textOnStdout(json_target)) {
        for (const auto& c : result.soil_bin_cases)
          std::cout << c.key.title() << ": " << c.repeats.size() << " repeat(s), force " << c.force_mean_N << " +- " << c.force_std_N
                    << " N, deformation " << c.deformation_mean_mm << " +- " << c.deformation_std_mm << " mm\n";
        for (const auto& c : result.calibration_cases)
          std::cout << c.key.title() << ": " << c.repeats.size() << " repeat(s), deformation steady " << c.deformation.steady.mean
                    << " mm, " << c.deformation.frequency_Hz.mean << " Hz, damping ratio " << c.deformation.damping_ratio.mean << "\n";
        std::cout << "report: " << (dir / "report.md").string() << "\n";
      }
    });
  });
}

}  // namespace demfem::cli

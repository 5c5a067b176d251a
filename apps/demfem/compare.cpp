// demfem compare: measured against simulated recordings per case (paper Sections 3.1, 3.6; Figs. 7,
// 8, 9, 14, 15, 17); tables, plots and a report (docs/analysis.md).
#include "analysis_options.hpp"
#include "commands.hpp"

#include <iostream>

namespace demfem::cli {

void addCompareCommand(CLI::App& app) {
  struct Options {
    AnalysisOptions analysis;
    std::string measured;
    std::string simulated;
    std::string simulated_tool;
  };
  auto options = std::make_shared<Options>();
  const AnalysisCommand command = addAnalysisCommand(app, "compare",
      "Compare measured and simulated recordings case by case (tool + depth_mm or mass_kg from the sidecars): "
      "mean differences, FFT power-law fits, calibration-weight frequency, damping and correlation",
      options->analysis, "comparison");
  CLI::App* cmd = command.cmd;
  cmd->add_option("measured", options->measured, "Measured recording or directory of recordings")->required();
  cmd->add_option("simulated", options->simulated, "Simulated recording or directory of recordings")->required();
  cmd->add_option("--simulated-tool", options->simulated_tool,
                  "Treat every simulated recording as this tool (the FEM client's sidecar names the tool after the study's tool "
                  "entry). Not needed when each side has one tool: cases are then matched by depth or mass");
  cmd->add_option("--fft-low-hz", options->analysis.settings.fft_low_Hz, "Lowest frequency of the power-law fits (default: common band)");
  cmd->add_option("--fft-high-hz", options->analysis.settings.fft_high_Hz, "Highest frequency of the power-law fits (default: common band)");
  std::string& json_target = *command.json_target;
  cmd->callback([options, &json_target] {
    runAnalysis([&] {
      finishAnalysisOptions(options->analysis);
      const OutputClaim claim(options->analysis.out_dir);
      const auto& settings = options->analysis.settings;
      if (!(settings.fft_high_Hz > settings.fft_low_Hz))
        throw InputError("--fft-low-hz/--fft-high-hz: the band is empty (" + std::to_string(settings.fft_low_Hz) + " to " +
                         std::to_string(settings.fft_high_Hz) + " Hz)");
      const auto measured = analysis::readRecordings({options->measured});
      const auto simulated = analysis::readRecordings(
          {options->simulated}, options->simulated_tool.empty() ? std::nullopt : std::optional<std::string>(options->simulated_tool));
      const auto result = analysis::compare(measured, simulated, settings);

      const auto dir = writeStaged(options->analysis, [&](analysis::StagedOutput& out, const analysis::GnuplotRenderer* renderer) {
        analysis::writeComparison(result, settings, out, renderer);
      });
      writeJson(json_target, analysis::toJson(result, settings));

      if (textOnStdout(json_target)) {
        if (const auto& renamed = result.simulated_tool_matched_as)
          std::cout << "simulated tool '" << renamed->first << "' compared as '" << renamed->second << "' (one tool on each side)\n";
        for (const auto& c : result.soil_bin)
          std::cout << c.key.title() << ": force mean difference " << c.force_difference_percent << " %, deformation mean difference "
                    << c.deformation_difference_percent << " %, fitted deformation spectrum ratio " << c.deformation_spectrum.mean_fitted_ratio
                    << "\n";
        for (const auto& c : result.calibration)
          std::cout << c.key.title() << ": deformation frequency " << c.measured.deformation.frequency_Hz.mean << " / "
                    << c.simulated.deformation.frequency_Hz.mean << " Hz (measured / simulated), correlation "
                    << c.correlations.front().deformation.correlation << "\n";
        for (const auto& u : result.unmatched_cases) std::cout << "not compared: " << u << "\n";
        std::cout << "report: " << (dir / "report.md").string() << "\n";
      }
    });
  });
}

}  // namespace demfem::cli

// `demfem soil-motion RUN_DIR [RUN_DIR...]`: the motion a tool caused in the soil of each run, read
// from its particle files (vtk/particles.pvd, vtk/dem-TOOL.pvd), side by side (Section 3.5, Fig. 16;
// analysis/soil_motion_report.hpp).
#include "analysis_options.hpp"
#include "commands.hpp"

#include "demfem/analysis/soil_motion_report.hpp"
#include "demfem/cli/cli_support.hpp"

#include <iostream>
#include <memory>
#include <sstream>

namespace demfem::cli {

namespace {

// The options' defaults are the analysis' own (in mm), so that the command and the paper report
// measure alike.
const analysis::SoilMotionSettings kDefaults{};

struct SoilMotionOptions {
  std::vector<std::string> runs;
  std::vector<double> at_mm{42.0};
  double threshold_mm_s = kDefaults.threshold_m_s * 1e3, cell_mm = kDefaults.cell_m * 1e3,
         front_reach_mm = kDefaults.front_reach_m * 1e3, mixing_cell_mm = kDefaults.mixing_cell_m * 1e3,
         flow_cell_mm = kDefaults.flow_cell_m * 1e3;
  std::string tool, rest_run, out_dir = "out/soil-motion", gnuplot = "gnuplot";
  bool no_plots = false;
};

analysis::SoilMotionSettings settingsOf(const SoilMotionOptions& o) {
  for (const double v : {o.threshold_mm_s, o.cell_mm, o.front_reach_mm, o.mixing_cell_mm, o.flow_cell_mm})
    if (!(v > 0)) throw InputError("--threshold-mm-s, --cell-mm, --front-reach-mm, --mixing-cell-mm and --flow-cell-mm must be > 0");
  analysis::SoilMotionSettings s;
  for (const double d : o.at_mm) s.displacements_m.push_back(d * 1e-3);
  s.threshold_m_s = o.threshold_mm_s * 1e-3;
  s.cell_m = o.cell_mm * 1e-3;
  s.half_thickness_m = 0.5 * s.cell_m;
  s.front_reach_m = o.front_reach_mm * 1e-3;
  s.mixing_cell_m = o.mixing_cell_mm * 1e-3;
  s.flow_cell_m = o.flow_cell_mm * 1e-3;
  s.tool = o.tool;
  s.rest_run = o.rest_run;
  return s;
}

std::string streamlineSummary(const analysis::SoilMotionInstant& in) {
  std::ostringstream out;
  if (in.order.cells)
    out << "alignment order " << in.order.order << " (random " << in.order.random_baseline << ")";
  else
    out << "no alignment order (no cell with 2 moving particles)";
  if (in.streamline_statistics.count)
    out << ", " << in.streamline_statistics.count << " streamlines of mean length " << in.streamline_statistics.mean_length_m * 1e3
        << " mm";
  else
    out << ", no streamline (nothing in motion)";
  return out.str();
}

void printRuns(const std::vector<analysis::SoilMotionRun>& runs, const std::filesystem::path& dir) {
  for (const auto& r : runs) {
    std::cout << r.name << " (tool " << r.tool << "): mixing " << r.mixing_before << " before, " << r.mixing_after << " after\n";
    for (const auto& in : r.instants)
      std::cout << "  at " << in.displacement_m * 1e3 << " mm: moving region " << in.extent.depth_m * 1e3 << " mm deep, "
                << in.extent.length_m * 1e3 << " mm long, " << in.extent.width_m * 1e3 << " mm wide; in front of the tool "
                << in.front.min_m_s * 1e3 << " - " << in.front.max_m_s * 1e3 << " mm/s (" << in.front.count << " particles); "
                << streamlineSummary(in) << "\n";
  }
  std::cout << "report: " << (dir / "soil-motion.md").string() << "\n";
}

}  // namespace

void addSoilMotionCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("soil-motion",
                                 "Soil motion of runs from their particle files (Section 3.5, Fig. 16): velocity sections as maps, the "
                                 "extent of the region in motion, speeds in front of the tool, streamline order, layer mixing before and after; several "
                                 "runs side by side. Writes soil-motion.json, soil-motion.md and plots/.");
  auto o = std::make_shared<SoilMotionOptions>();
  cmd->add_option("RUN_DIR", o->runs, "Run output directories (with vtk/particles.pvd)")->required()->check(CLI::ExistingDirectory);
  cmd->add_option("--at-mm", o->at_mm, "Tool displacements to analyse (mm, repeatable)")->capture_default_str();
  cmd->add_option("--threshold-mm-s", o->threshold_mm_s, "Speed above which a particle is in motion (mm/s)")->capture_default_str();
  cmd->add_option("--cell-mm", o->cell_mm, "Cell size of the velocity maps; sections are one cell thick (mm)")->capture_default_str();
  cmd->add_option("--front-reach-mm", o->front_reach_mm, "How far ahead of the front face 'in front of the tool' reaches (mm)")
      ->capture_default_str();
  cmd->add_option("--mixing-cell-mm", o->mixing_cell_mm, "Cell size of the layer-mixing measure (mm)")->capture_default_str();
  cmd->add_option("--flow-cell-mm", o->flow_cell_mm, "Cell size of the streamline-order flow section on the vertical section (mm)")
      ->capture_default_str();
  cmd->add_option("--tool", o->tool, "Tool whose motion is analysed (default: the run's only tool)");
  cmd->add_option("--rest-run", o->rest_run,
                  "A run of the same bed left alone (vtk/particles.pvd at the runs' times, e.g. demfem-bench-soil-bed --rest-vtk): "
                  "velocities are taken against it, so the bed's own creep is not motion")
      ->check(CLI::ExistingDirectory);
  cmd->add_option("--out,--output", o->out_dir, "Output directory")->capture_default_str();
  addPlotOptions(*cmd, o->no_plots, o->gnuplot, "SVG and PNG plots");
  std::string& json_target = addJsonOption(*cmd);
  cmd->callback([o, &json_target] {
    runAnalysis([&] {
      const OutputClaim claim(o->out_dir);
      const auto settings = settingsOf(*o);
      std::vector<analysis::SoilMotionRun> runs;
      for (const auto& dir : o->runs) runs.push_back(analysis::analyseRun(dir, settings));
      analysis::StagedOutput out(o->out_dir);
      const analysis::GnuplotRenderer renderer(o->gnuplot);
      analysis::writeSoilMotionOutputs(out, runs, settings, o->no_plots ? nullptr : &renderer);
      out.commit();
      writeJson(json_target, analysis::soilMotionJson(runs, settings));
      if (textOnStdout(json_target)) printRuns(runs, out.directory());
    });
  });
}

}  // namespace demfem::cli

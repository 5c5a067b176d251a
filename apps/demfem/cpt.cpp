// `demfem cpt STUDY [STUDY...]` (and `demfem run` on a cone-penetration study): the penetrometers of
// each study pushed down through its DEM backend in this process (adapter/cone_drive.hpp), CPR
// against depth per cone, mean, std and mean deviation per study side by side, compared with
// measured CPR profiles (analysis/cpt_report.hpp).
#include "analysis_options.hpp"
#include "commands.hpp"

#include "demfem/adapter/cone_drive.hpp"
#include "demfem/adapter/settled_soil.hpp"
#include "demfem/analysis/cpt_report.hpp"
#include "demfem/analysis/recording.hpp"
#include "demfem/campaign/model.hpp"
#include "demfem/campaign/parameters.hpp"
#include "demfem/cli/cli_support.hpp"
#include "demfem/cli/progress.hpp"
#include "demfem/cli/soil_supply.hpp"
#include "demfem/study/study.hpp"

#include <algorithm>
#include <atomic>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>

namespace demfem::cli {

namespace {

std::atomic<bool> g_stop{false};
extern "C" void onCptStopSignal(int) { g_stop = true; }

// The cones' records as CPR profiles (samples below the surface only).
analysis::CptSoil cptSoil(const study::Study& study, const std::vector<adapter::ConeRecord>& records) {
  analysis::CptSoil soil{study.name, records.front().area_m2, {}, {}};
  for (const auto& r : records) {
    analysis::CprProfile p{r.name, {}, {}};
    for (std::size_t k = 0; k < r.time_s.size(); ++k)
      if (r.tip_depth_m[k] > 0) {
        p.depth_m.push_back(r.tip_depth_m[k]);
        p.cpr_Pa.push_back(analysis::coneResistance_Pa(r.force_N[k], r.area_m2));
      }
    soil.cones.push_back(std::move(p));
  }
  return soil;
}

// --packing: the study's soil file made from the packing study's deposition (campaign/model.hpp,
// shared packing), and refused when a file made otherwise is already there.
void sharePacking(const study::Study& study, const std::string& packing_file, bool quiet) {
  const study::Study packing = loadCheckedStudy(packing_file);
  for (const auto* s : {&packing, &study})
    if (s->soil.deposition_backend != "builtin")
      throw InputError(s->name + ": /soil/deposition/backend: --packing shares a built-in deposition only");
  try {
    campaign::SoilBinModel(campaign::SoilForce::Draught, packing).prepare({study}, depositionProgress(!quiet));
  } catch (const campaign::ArgumentError& e) {
    throw InputError("--packing " + packing_file + ": " + e.what());
  }
  study::Study reference = packing;
  reference.soil.deposition_seed = study.soil.deposition_seed;
  const auto dir = adapter::defaultSoilDirectory();
  const auto file = adapter::settledSoilFile(study, dir);
  const auto own = adapter::readSettledSoil(file, study).particles;
  const auto shared = adapter::readSettledSoil(adapter::settledSoilFile(reference, dir), reference).particles;
  const auto same = [](const adapter::SoilParticle& a, const adapter::SoilParticle& b) { return a.x_m == b.x_m && a.radius_m == b.radius_m; };
  if (!std::equal(own.begin(), own.end(), shared.begin(), shared.end(), same))
    throw InputError(file.string() + ": the settled soil of '" + study.name + "' is another deposition than --packing " + packing_file +
                     "'s; remove it or use another soil directory");
}

analysis::CptSoil pushStudyCones(const std::string& study_file, const CptOptions& o) {
  study::Study study = loadCheckedStudy(study_file);
  if (study.kind != study::StudyKind::ConePenetration)
    throw InputError(study_file + ": /kind: demfem cpt runs cone-penetration studies only");
  if (o.threads > 0) study.dem.threads = o.threads;
  study.output.directory = std::filesystem::path(o.output_dir) / "runs" / study.name;  // the backend's VTK files
  if (!o.packing.empty()) sharePacking(study, o.packing, o.quiet);
  const BackendEntry& backend = findBackend(o.backend.empty() ? study.dem.backend : o.backend);
  if (!backend.capabilities.simulates_soil)
    throw InputError("backend '" + backend.capabilities.name + "' simulates no soil: cone penetration needs a soil backend");
  const auto dem = openSoilBackend(backend, study, o.allow_unsettled_soil);
  Progress progress("cone penetration " + study.name, !o.quiet);
  const auto records = adapter::pushCones(*dem, study, [&](std::int64_t done, std::int64_t total) {
    if (g_stop) throw Interrupted("cone penetration of " + study_file + " stopped after " + std::to_string(done) + " of " +
                                  std::to_string(total) + " intervals: no results written");
    char detail[96];
    std::snprintf(detail, sizeof detail, "%.2f s of %.2f s simulated", static_cast<double>(done) * study.fem.dt_s,
                  static_cast<double>(total) * study.fem.dt_s);
    progress.update(static_cast<double>(done) / static_cast<double>(total), detail);
  });
  progress.finish(std::to_string(records.size()) + " cones");
  dem->shutdown();
  return cptSoil(study, records);
}

void printSummary(const analysis::CptResults& r, const std::filesystem::path& dir) {
  for (const auto& soil : r.soils) {
    const auto& s = soil.summary;
    std::cout << soil.study << ": " << s.profiles << " cones, CPR at " << s.depth_m.back() * 1e3 << " mm " << s.mean_Pa.back() * 1e-3
              << " +- " << s.std_Pa.back() * 1e-3 << " kPa, mean deviation " << 100 * s.mean_deviation << " %\n";
  }
  if (r.measured)
    std::cout << r.measured->soil << ": " << r.measured->profiles << " repeats, mean deviation " << 100 * r.measured->mean_deviation << " %\n";
  for (const auto& c : r.comparisons)
    std::cout << c.simulated << " against " << c.measured << ": within the measured band at " << 100 * c.within_measured_band << " % of "
              << c.depths << " depths, mean relative difference " << 100 * c.mean_relative_difference << " %\n";
  std::cout << "report: " << (dir / "cpt.md").string() << "\n";
}

}  // namespace

void runConePenetration(const std::vector<std::string>& study_files, const CptOptions& o, const std::string& json_target) {
  if (!(o.depth_step_mm > 0)) throw InputError("--depth-step-mm: must be > 0");
  const OutputClaim claim(o.output_dir);
  std::signal(SIGINT, onCptStopSignal);
  std::signal(SIGTERM, onCptStopSignal);
  std::vector<analysis::CptSoil> soils;
  for (const auto& file : study_files) soils.push_back(pushStudyCones(file, o));
  runAnalysis([&] {
    std::vector<analysis::MeasuredProfile> measured;
    for (const auto& m : o.measured) measured.push_back(analysis::readMeasuredProfile(m));
    const auto results = analysis::evaluateCpt(std::move(soils), measured, o.depth_step_mm * 1e-3);
    analysis::StagedOutput out(o.output_dir);
    const analysis::GnuplotRenderer renderer(o.gnuplot);
    analysis::writeCptOutputs(out, results, o.no_plots ? nullptr : &renderer);
    out.commit();
    writeJson(json_target, analysis::cptJson(results));
    if (textOnStdout(json_target)) printSummary(results, out.directory());
  });
}

namespace {

void addCptOptions(CLI::App& cmd, CptOptions& o) {
  cmd.add_option("--measured", o.measured, "Measured CPR profiles: CSV depth_mm,CPR_kPa with a JSON sidecar (repeatable)")
      ->check(CLI::ExistingFile);
  cmd.add_option("--depth-step-mm", o.depth_step_mm, "Depth grid of the statistics (mm)")->capture_default_str();
  cmd.add_option("--backend", o.backend, "DEM backend (default: the study's dem.backend)");
  cmd.add_option("--packing", o.packing,
                 "Study whose built-in deposition every study's soil holds (same bin, fill height and particle sizes), each particle "
                 "tagged with the study's layer at its depth: the studies then differ by friction only, as the paper's layered "
                 "and non-layered assemblies")
      ->check(CLI::ExistingFile);
  cmd.add_option("--threads", o.threads, "OpenMP threads of the built-in DEM (default: the study's dem.threads)")->check(CLI::PositiveNumber);
  addAllowUnsettledSoilFlag(cmd, o.allow_unsettled_soil);
  addPlotOptions(cmd, o.no_plots, o.gnuplot, "SVG and PNG plots");
  cmd.add_flag("--quiet", o.quiet, "No progress output");
}

}  // namespace

void addCptCommand(CLI::App& app) {
  auto* cmd = app.add_subcommand("cpt",
                                 "Cone penetration test (Section 2.10.3, Fig. 10): push each study's penetrometers down through its DEM, "
                                 "CPR against depth per cone, mean, std and mean deviation per study side by side, compared with "
                                 "measured CPR profiles. Writes cpt.json, cpt.md, profiles/ and plots/cpr.{svg,png}.");
  auto studies = std::make_shared<std::vector<std::string>>();
  auto o = std::make_shared<CptOptions>();
  cmd->add_option("STUDY", *studies, "Cone-penetration studies (e.g. studies/cpt.json studies/cpt_unlayered.json)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--out,--output", o->output_dir, "Output directory")->capture_default_str();
  addCptOptions(*cmd, *o);
  std::string& json_target = addJsonOption(*cmd);
  cmd->callback([studies, o, &json_target] { runConePenetration(*studies, *o, json_target); });
}

}  // namespace demfem::cli

// `demfem campaign STUDY...`: the paper's cases run and resumed (campaign/paper_campaign.hpp), or
// with --report the report of their finished runs (campaign/paper_report.hpp).
#include "commands.hpp"
#include "run_cost.hpp"
#include "demfem/analysis/recording.hpp"
#include "demfem/campaign/calibration.hpp"
#include "demfem/campaign/paper_campaign.hpp"
#include "demfem/campaign/paper_report.hpp"
#include "demfem/campaign/parameters.hpp"
#include "demfem/cli/cli_support.hpp"
#include "demfem/cli/progress.hpp"

#include <atomic>
#include <chrono>
#include <csignal>
#include <fstream>
#include <cstdio>
#include <iostream>
#include <memory>

namespace demfem::cli {

namespace {

std::atomic<bool> g_campaign_stop{false};
extern "C" void onCampaignStop(int) { g_campaign_stop = true; }

struct CampaignOptions {
  std::vector<std::string> studies;
  campaign::CampaignOptions run;
  std::string directory = "campaign";
  std::int64_t steps = 0;
  std::string report_dir;
  std::string label;
  std::vector<std::string> convergence;
  std::string gnuplot = "gnuplot";
  bool no_plots = false;
  bool quiet = false;
};

campaign::ConvergenceSummary readConvergence(const std::string& file) {
  std::ifstream in(file);
  if (!in) throw InputError("--convergence: cannot read " + file);
  try {
    return campaign::convergenceFromJson(nlohmann::json::parse(in));
  } catch (const nlohmann::json::exception& e) {
    throw InputError("--convergence " + file + ": not the JSON of demfem-bench-paper-convergence: " + e.what());
  }
}

double estimateWallSeconds(const study::Study& s) { return estimateRunCost(s).wallSeconds(); }

// One line per running case and the overall time left, every 10 s (5 s while starting).
class ProgressLines {
 public:
  explicit ProgressLines(bool enabled) : enabled_(enabled) {}
  void operator()(const campaign::CampaignProgress& p) {
    const auto now = std::chrono::steady_clock::now();
    if (!enabled_ || now - last_ < std::chrono::seconds(p.elapsed_s < 60 ? 5 : 10)) return;
    last_ = now;
    int done = 0;
    for (const campaign::CaseStatus& c : *p.cases) {
      if (c.state == campaign::CaseState::Done) ++done;
      if (c.state != campaign::CaseState::Running) continue;
      const double pct = c.total_steps > 0 ? 100.0 * static_cast<double>(c.step) / static_cast<double>(c.total_steps) : 0.0;
      std::fprintf(stderr, "campaign: %s%s: %.0f %% (%lld of %lld FEM steps) ETA %s\n", c.name.c_str(), c.resumed ? " (resumed)" : "", pct,
                   static_cast<long long>(c.step), static_cast<long long>(c.total_steps), Progress::formatDuration(c.eta_s).c_str());
    }
    std::fprintf(stderr, "campaign: %d of %zu cases done, overall ETA %s\n", done, p.cases->size(), Progress::formatDuration(p.overall_eta_s).c_str());
  }

 private:
  bool enabled_;
  std::chrono::steady_clock::time_point last_{};
};

void printSummary(const campaign::CampaignSummary& s) {
  for (const campaign::CaseStatus& c : s.cases)
    std::printf("%s: %s%s, %.0f s (estimated %.0f s)%s%s\n", c.name.c_str(), campaign::caseStateName(c.state),
                c.done_before ? " before this call" : (c.resumed ? ", resumed" : ""), c.wall_s, c.estimate_wall_s,
                c.message.empty() ? "" : ": ", c.message.c_str());
}

void run(CampaignOptions& o, const std::string& json_target) {
  std::vector<std::filesystem::path> files(o.studies.begin(), o.studies.end());
  if (!o.report_dir.empty()) {
    const analysis::GnuplotRenderer renderer(o.gnuplot);
    campaign::ReportOptions r;
    r.directory = o.directory;
    r.label = o.label;
    r.estimate_wall_s = estimateWallSeconds;
    r.renderer = o.no_plots ? nullptr : &renderer;
    for (const std::string& file : o.convergence) r.convergence.push_back(readConvergence(file));
    analysis::StagedOutput out(o.report_dir);
    const nlohmann::json doc = campaign::writePaperReport(files, r, out);
    out.commit();
    writeJson(json_target, doc);
    if (textOnStdout(json_target)) std::printf("report: %s\n", (out.directory() / "paper-reproduction.md").c_str());
    return;
  }
  o.run.directory = o.directory;
  if (o.steps > 0) o.run.max_steps = o.steps;
  o.run.estimate_wall_s = estimateWallSeconds;
  auto lines = std::make_shared<ProgressLines>(!o.quiet);
  o.run.on_progress = [lines](const campaign::CampaignProgress& p) { (*lines)(p); };
  o.run.on_deposit = depositionProgress(!o.quiet);
  std::signal(SIGINT, onCampaignStop);
  std::signal(SIGTERM, onCampaignStop);
  o.run.stop_requested = [] { return g_campaign_stop.load(); };
  const campaign::CampaignSummary summary = campaign::runCampaign(files, o.run);
  writeJson(json_target, campaign::toJson(summary));
  if (textOnStdout(json_target)) printSummary(summary);
  for (const campaign::CaseStatus& c : summary.cases)
    if (c.state == campaign::CaseState::Failed) throw std::runtime_error("case " + c.name + " failed: " + c.message);
}

}  // namespace

void addCampaignCommand(CLI::App& app) {
  auto o = std::make_shared<CampaignOptions>();
  auto* cmd = app.add_subcommand(
      "campaign",
      "Run soil-bin studies as the cases of one campaign (the paper's nine: studies/paper/*.json), each in DIR/STEM with "
      "checkpoints; run again to resume (finished cases are not rerun, interrupted ones continue from their checkpoint). "
      "With --report OUT, write OUT/paper-reproduction.md from the finished runs instead, beside the paper's numbers");
  cmd->add_option("STUDY", o->studies, "Study files, one per case (coupled or dem-only, built-in DEM)")->required()->check(CLI::ExistingFile);
  cmd->add_option("--dir,--out,--output", o->directory, "Directory of the cases' run directories")->capture_default_str();
  cmd->add_option("--jobs", o->run.jobs, "Cases run at once")->check(CLI::PositiveNumber)->capture_default_str();
  cmd->add_option("--threads", o->run.threads, "Built-in DEM threads per case; default: the study's dem.threads / jobs")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--checkpoint-every", o->run.checkpoint_every, "FEM steps between checkpoints")->check(CLI::PositiveNumber)->capture_default_str();
  cmd->add_option("--steps", o->steps, "Stop each case after this many FEM steps (marked incomplete; a later call continues)")
      ->check(CLI::PositiveNumber);
  cmd->add_option("--report", o->report_dir, "Write the report of the finished runs to this directory (runs nothing)");
  cmd->add_option("--convergence", o->convergence, "With --report: the time-step table of demfem-bench-paper-convergence --json FILE (repeatable: one table each, in this order)")
      ->check(CLI::ExistingFile);
  cmd->add_option("--label", o->label, "Text the report names its runs by (e.g. the source revision they came from)");
  addPlotOptions(*cmd, o->no_plots, o->gnuplot, "report's SVG plots");
  addAllowUnsettledSoilFlag(*cmd, o->run.allow_unsettled_soil);
  cmd->add_flag("--quiet", o->quiet, "No progress on stderr");
  std::string& json_target = addJsonOption(*cmd);
  cmd->callback([o, &json_target] {
    try {
      run(*o, json_target);
    } catch (const campaign::ArgumentError& e) {
      throw InputError(e.what());
    } catch (const analysis::InputError& e) {
      throw InputError(e.what());
    } catch (const campaign::Interrupted& e) {
      throw Interrupted(e.what());
    }
  });
}

}  // namespace demfem::cli

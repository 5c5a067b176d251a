// Time-step convergence on a reduced paper bin (campaign/paper_convergence.hpp): the case run at
// halved fractions of the stiffest spring's critical step (from the largest given towards the
// paper's), each at every deposition seed, every fraction of a seed dragging through that seed's
// one packing, so that the step's effect is measured seed by seed; all as one campaign
// (campaign/paper_campaign.hpp: resumable, a second call reruns nothing). Prints the Markdown table
// of docs/paper-reproduction.md; --json writes the numbers (`demfem campaign --report
// --convergence FILE` puts them in the report).
#include "demfem/backends/physics/time_step.hpp"
#include "demfem/campaign/calibration.hpp"
#include "demfem/campaign/model.hpp"
#include "demfem/campaign/paper_campaign.hpp"
#include "demfem/campaign/paper_convergence.hpp"
#include "demfem/campaign/paper_report.hpp"
#include "demfem/cli/cli_support.hpp"
#include "demfem/cli/progress.hpp"
#include "demfem/study/tool_motion.hpp"

#include <atomic>
#include <csignal>
#include <cstdio>
#include <fstream>

namespace {

namespace fs = std::filesystem;
using namespace demfem;

std::atomic<bool> g_stop{false};
extern "C" void onStop(int) { g_stop = true; }

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"demfem-bench-paper-convergence: force, deformation and FFT fit of a reduced paper bin against the DEM step"};
  app.name("demfem-bench-paper-convergence");
  std::string study_file = std::string(DEMFEM_SOURCE_DIR) + "/studies/paper/pmma_coupled_42.json";
  std::string work = "paper-convergence";
  double length_mm = 200, width_mm = 100, stroke_mm = 100, largest = 0.4, seed_fraction = 0.1;
  int halvings = 3, seeds = 2, threads = 1, jobs = 2;
  app.add_option("--study", study_file, "paper case the reduced bin is cut from")->check(CLI::ExistingFile)->capture_default_str();
  app.add_option("--dir", work, "campaign directory of the runs (kept: a second call reruns nothing)")->capture_default_str();
  app.add_option("--length-mm", length_mm, "bin length")->capture_default_str();
  app.add_option("--width-mm", width_mm, "bin width")->capture_default_str();
  app.add_option("--stroke-mm", stroke_mm, "tool stroke")->capture_default_str();
  app.add_option("--largest-fraction", largest, "coarsest fraction of the critical step")->check(CLI::Range(1e-6, 1.0))->capture_default_str();
  app.add_option("--halvings", halvings, "fractions after the coarsest, each half the one before")->check(CLI::NonNegativeNumber)->capture_default_str();
  app.add_option("--seeds", seeds, "deposition seeds; every fraction drags through each seed's packing")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--seed-fraction", seed_fraction, "fraction the packings are deposited at (one of the halvings)")->capture_default_str();
  app.add_option("--threads", threads, "DEM threads per case")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--jobs", jobs, "cases at once")->check(CLI::PositiveNumber)->capture_default_str();
  std::string& json_target = cli::addJsonOption(app);
  app.callback([&] {
    const nlohmann::ordered_json base = cli::readJsonFile(study_file);
    const fs::path studies = fs::path(work) / "studies";
    fs::create_directories(studies);
    std::vector<fs::path> files;
    std::vector<study::Study> case_studies;
    std::vector<std::pair<double, std::uint64_t>> variants;
    for (int seed = 1; seed <= seeds; ++seed) {
      double f = largest;
      for (int h = 0; h <= halvings; ++h, f /= 2) variants.emplace_back(f, static_cast<std::uint64_t>(seed));
    }
    for (const auto& [fraction, seed] : variants) {
      nlohmann::ordered_json s = campaign::reducedStudy(base, length_mm, width_mm, stroke_mm, fraction, seed);
      s["dem"]["threads"] = threads;
      const fs::path file = studies / (s["name"].get<std::string>() + ".json");
      std::ofstream out(file);
      out << s.dump(2) << '\n';
      out.close();
      if (!out) throw std::runtime_error("cannot write " + file.string());
      files.push_back(file);
      case_studies.push_back(study::loadStudy(file));
    }
    // One packing per seed (the seed fraction's deposition), shared by every fraction: the runs of
    // one seed differ in their step only (campaign/model.hpp, shared packing).
    study::Study packing = case_studies.front();
    for (const study::Study& s : case_studies)
      if (s.dem.dt_fraction == seed_fraction) packing = s;
    campaign::SoilBinModel(campaign::SoilForce::LoadCell, packing).prepare(case_studies, cli::depositionProgress(true));
    campaign::CampaignOptions o;
    o.directory = fs::path(work) / "runs";
    o.jobs = jobs;
    o.threads = threads;
    cli::Progress progress("convergence");
    // The runs of this call, each weighed by its cost (DEM steps go as 1 / fraction; every run has
    // the same FEM steps); runs kept from an earlier call are not part of the time left. The time
    // left is the work left at the rate of this call's work, not counting the steps a run resumed
    // from its checkpoint had done before.
    std::vector<std::int64_t> first_step(variants.size(), -1);
    o.on_progress = [&progress, &variants, &first_step](const campaign::CampaignProgress& p) {
      std::int64_t plan = 0;
      for (const campaign::CaseStatus& c : *p.cases) plan = std::max(plan, c.total_steps);
      double done = 0, total = 0, done_now = 0;
      int runs = 0;
      for (std::size_t i = 0; i < p.cases->size(); ++i) {
        const campaign::CaseStatus& c = (*p.cases)[i];
        if (c.done_before) continue;
        const double cost = 1.0 / variants[i].first;
        const std::int64_t step = c.state == campaign::CaseState::Done ? plan : c.step;
        if (first_step[i] < 0 && c.step > 0) first_step[i] = c.step - 1;  // its first report is one step on
        total += cost * static_cast<double>(plan), ++runs;
        done += cost * static_cast<double>(step);
        done_now += cost * static_cast<double>(step - std::max<std::int64_t>(first_step[i], 0));
      }
      if (!(total > 0)) return;
      const double left = done_now > 0 ? (total - done) * p.elapsed_s / done_now : -1.0;
      progress.update(done / total, left, std::to_string(runs) + " runs to make");
    };
    std::signal(SIGINT, onStop);
    o.stop_requested = [] { return g_stop.load(); };
    const campaign::CampaignSummary summary = campaign::runCampaign(files, o);
    progress.finish();
    std::vector<campaign::ConvergencePoint> points;
    double window_begin_mm = 0, window_end_mm = 0;
    for (std::size_t i = 0; i < files.size(); ++i) {
      const campaign::CaseStatus& c = summary.cases[i];
      const study::Study st = study::loadStudy(c.run_dir / "study.json");
      const double dt_s = study::demStepDividing(physics::demTimeStep(st).step_s, st.fem.dt_s);
      if (c.state != campaign::CaseState::Done) {  // a blow-up: this step is unstable
        campaign::ConvergencePoint failed;
        failed.dt_fraction = variants[i].first;
        failed.dt_s = dt_s;
        failed.seed = variants[i].second;
        failed.wall_s = c.wall_s;
        failed.failure = c.message;
        points.push_back(failed);
        continue;
      }
      const campaign::RunEvaluation e = campaign::evaluateCampaignRun(c.run_dir, st);
      window_begin_mm = e.window_begin_mm;
      window_end_mm = e.window_end_mm;
      points.push_back({variants[i].first, dt_s, variants[i].second,
                        e.window.force_N.mean, e.window.force_N.std_dev, e.window.deformation_mm.mean, e.window.deformation_mm.std_dev,
                        e.fit.b, e.fit.a, e.wall_s, {}});
    }
    char caption[256];
    std::snprintf(caption, sizeof caption, "%s cut to a %.0f x %.0f mm bin, %.0f mm stroke (window %.0f-%.0f mm)", fs::path(study_file).stem().c_str(),
                  length_mm, width_mm, stroke_mm, window_begin_mm, window_end_mm);
    const campaign::ConvergenceSummary s = campaign::summarize(points, caption);
    cli::writeJson(json_target, campaign::toJson(s));
    if (cli::textOnStdout(json_target)) std::fputs(campaign::markdown(s).c_str(), stdout);
  });
  return cli::runApp(app, argc, argv);
}

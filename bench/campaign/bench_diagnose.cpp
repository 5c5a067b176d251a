// Diagnosis benchmark (docs/diagnosis.md, section Cost): the wall and processor time of a weight-drop
// diagnosis of the paper's PMMA tool (0.5 and 1 kg, two repeats each) on recordings the project's
// modal model made with a compliant clamp (k_theta = --clamp-ei-l times the free part's EI/L) and
// DAQ noise, every cause of the catalogue fitted. Prints a table per cause; --json writes the same.
#include "demfem/campaign/diagnose.hpp"
#include "demfem/cli/cli_support.hpp"
#include "truth_recordings.hpp"

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <ctime>

namespace {

using Clock = std::chrono::steady_clock;
namespace fs = std::filesystem;
using namespace demfem;

double secondsSince(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }
double cpuSeconds() { return static_cast<double>(std::clock()) / CLOCKS_PER_SEC; }

// EI / L of the tool's free part (below the clamp), N m/rad.
double freePartEiOverL(const nlohmann::ordered_json& tool) {
  const double E = tool["fem"]["E_Pa"], W = tool["geometry"]["width_mm"], T = tool["geometry"]["thickness_mm"];
  const double L = tool["geometry"]["length_mm"].get<double>() - tool["constraints"]["clamp_length_mm"].get<double>();
  return E * (W * 1e-3) * std::pow(T * 1e-3, 3) / 12 / (L * 1e-3);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"demfem-bench-diagnose: cost of a weight-drop diagnosis of the paper tool with compliant-clamp recordings"};
  app.name("demfem-bench-diagnose");
  std::string study_file = std::string(DEMFEM_SOURCE_DIR) + "/studies/weight_drop_1kg.json";
  double clamp_ei_l = 3.0;
  int jobs = 2;
  app.add_option("--study", study_file, "weight-drop study of the tool")->check(CLI::ExistingFile)->capture_default_str();
  app.add_option("--clamp-ei-l", clamp_ei_l, "the recordings' clamp spring in units of EI/L")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--jobs", jobs, "cases run concurrently")->check(CLI::PositiveNumber)->capture_default_str();
  std::string& json_target = cli::addJsonOption(app);
  app.callback([&] {
    const nlohmann::ordered_json study = cli::readJsonFile(study_file);
    nlohmann::ordered_json truth = study;
    const double k_true = clamp_ei_l * freePartEiOverL(study["tools"][0]);
    truth["tools"][0]["constraints"]["clamp_rotational_stiffness_Nm_per_rad"] = k_true;
    const fs::path dir = fs::temp_directory_path() / ("demfem-bench-diagnose-" + std::to_string(getpid()));
    fs::create_directories(dir / "recordings");
    std::fprintf(stderr, "writing the recordings (k_theta = %.4g N m/rad)\n", k_true);
    auto t = Clock::now();
    bench::writeTruth(truth, study_file, dir / "recordings");
    const double recordings_s = secondsSince(t);
    const auto recordings = analysis::readRecordings({dir / "recordings"});

    campaign::DiagnosisSettings settings;
    settings.calibration.jobs = jobs;
    settings.calibration.kind = campaign::ObjectiveKind::Smooth;
    settings.calibration.cache_dir = dir / "runs";
    const auto start = Clock::now();
    settings.on_stage = [start](const std::string& stage) { std::fprintf(stderr, "diagnose: %s (%.0f s elapsed)\n", stage.c_str(), secondsSince(start)); };
    const auto model = campaign::makeModel(study::parseStudy(study.dump(), study_file));
    t = Clock::now();
    const double c0 = cpuSeconds();
    const campaign::Diagnosis d = campaign::diagnose(study, study_file, recordings, *model, settings);
    const double wall_s = secondsSince(t), cpu_s = cpuSeconds() - c0;
    fs::remove_all(dir);

    std::printf("%-20s %10s %12s %14s %14s\n", "cause", "runs", "wall (s)", "before (%)", "after (%)");
    nlohmann::json causes = nlohmann::json::array();
    int runs = 0;
    for (const auto& c : d.ranking) {
      if (!c.fitted) continue;
      runs += c.model_runs;
      std::printf("%-20s %10d %12.2f %14.2f %14.2f\n", c.id.c_str(), c.model_runs, c.wall_time_s, c.error_before_percent, c.error_after_percent);
      causes.push_back({{"id", c.id},
                        {"model_runs", c.model_runs},
                        {"wall_s", c.wall_time_s},
                        {"error_before_percent", c.error_before_percent},
                        {"error_after_percent", c.error_after_percent}});
    }
    std::printf("%-20s %10d %12.2f   (processor %.1f s, recordings %.1f s)\n", "whole diagnosis", runs, wall_s, cpu_s, recordings_s);
    std::printf("named cause: %s\n", d.cause ? d.cause->c_str() : "no significant discrepancy");
    cli::writeJson(json_target, {{"study", study_file},
                                 {"clamp_true_Nm_per_rad", k_true},
                                 {"jobs", jobs},
                                 {"recordings_s", recordings_s},
                                 {"diagnosis_wall_s", wall_s},
                                 {"diagnosis_cpu_s", cpu_s},
                                 {"cause", d.cause ? nlohmann::json(*d.cause) : nlohmann::json(nullptr)},
                                 {"causes", causes}});
  });
  return cli::runApp(app, argc, argv);
}

// Soil calibration benchmark (docs/calibration.md, "Cost of a soil calibration"): the layered-bin
// fixture of the physics test (tests/campaign/liggghts_layered_bin.hpp: LIGGGHTS itself from the deck
// kept with the test, friction 0.2 above and 0.9 below the interface), by default the small bin of
// the issue (100 x 330 mm, about 2,570 particles, 200 mm stroke, depths 20, 40, 55 mm, three seeds),
// then `--preset layered-soil` of the two-layer built-in study on every recording and the calibrated
// study's prediction of every depth, optionally the single-layer fit at the shallowest depth. Prints
// the fitted against the deck's values, the draught per depth, the model runs, wall and processor
// time and the load average before and after; --json writes the same numbers.
#include "bench_timing.hpp"
#include "layered_soil_study.hpp"

#include "demfem/cli/cli_support.hpp"

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <regex>

namespace {

namespace fs = std::filesystem;
using namespace demfem;
using bench::Clock;

// The deck's friction variables (`variable NAME index VALUE` in materials.in): the truth.
std::map<std::string, double> deckVariables() {
  const fs::path file = campaign::test::layeredBinDeck() / "materials.in";
  std::ifstream in(file);
  if (!in) throw std::runtime_error("cannot read " + file.string());
  std::map<std::string, double> out;
  const std::regex line(R"(^variable\s+(\w+)\s+index\s+(\S+))");
  std::smatch m;
  for (std::string text; std::getline(in, text);)
    if (std::regex_search(text, m, line)) out[m[1]] = std::stod(m[2]);
  return out;
}

// The deck's value of a preset parameter (`/soil/interactions/N/static_friction` or
// `rolling_friction`) of the built-in study, from the pair's materials (top, bottom, steel).
double deckValue(const nlohmann::ordered_json& study, const std::string& pointer, const std::map<std::string, double>& deck) {
  const auto& pair = study.at(nlohmann::json::json_pointer(pointer).parent_pointer())["materials"];
  const std::string a = pair[0], b = pair[1];
  std::string variable = "mur";
  if (pointer.ends_with("/static_friction"))
    variable = a == "steel" || b == "steel" ? "mu_wall" : a != b ? "mu_between" : "mu_" + a;
  const auto it = deck.find(variable);
  if (it == deck.end()) throw std::runtime_error("the deck sets no " + variable + " (the truth of " + pointer + ")");
  return it->second;
}

std::size_t cachedRuns(const fs::path& dir) {
  std::size_t n = 0;
  if (fs::is_directory(dir))
    for (const auto& e : fs::directory_iterator(dir)) n += e.path().extension() == ".json";
  return n;
}

// Per stage: the fitted parameters (against the deck's values when `deck` is given), evaluations,
// runs and wall time; printed and returned.
nlohmann::json stagesJson(const campaign::StagedCalibration& c, const nlohmann::ordered_json& study, const std::map<std::string, double>* deck,
                          std::FILE* table) {
  nlohmann::json out = nlohmann::json::array();
  for (std::size_t k = 0; k < c.results.size(); ++k) {
    const auto& r = c.results[k];
    nlohmann::json parameters = nlohmann::json::array();
    for (const auto& p : r.parameters) {
      nlohmann::json row = {{"pointer", p.spec.pointer}, {"fitted", p.best}, {"std_dev", p.std_dev}, {"identified", p.identified}};
      std::fprintf(table, "  %-36s", p.spec.pointer.c_str());
      if (deck) {
        row["true"] = deckValue(study, p.spec.pointer, *deck);
        std::fprintf(table, " true %6.3f ", row["true"].get<double>());
      }
      std::fprintf(table, " fitted %6.3f +- %-8.3g%s\n", p.best, p.std_dev, p.identified ? "" : " (unidentified)");
      parameters.push_back(row);
    }
    std::fprintf(table, "  stage %zu: %d evaluations, %d model runs, %d cache hits, %d failed, %.0f s wall\n", k + 1, r.evaluations, r.model_runs,
                r.cache_hits, r.failed_runs, r.wall_time_s);
    out.push_back({{"title", c.stages[k].title},
                   {"parameters", parameters},
                   {"evaluations", r.evaluations},
                   {"model_runs", r.model_runs},
                   {"cache_hits", r.cache_hits},
                   {"failed_runs", r.failed_runs},
                   {"wall_s", r.wall_time_s}});
  }
  return out;
}

nlohmann::json seedJson(const campaign::test::SeedMean& m) { return {{"mean_N", m.mean_N}, {"sd_N", m.sd_N}, {"failed_runs", m.failed_runs}}; }

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"demfem-bench-soil-calibrate: cost of a two-layer soil calibration of the small bin against LIGGGHTS itself"};
  app.name("demfem-bench-soil-calibrate");
  campaign::test::LayeredBin bin;
  bool ci_bin = false, single_layer = false;
  int max_evaluations = 12, model_seeds = 3;
  double window_begin_mm = campaign::test::kSmallBinWindowBeginMm;
  std::string out_dir = "bench-soil", recordings_dir;
  app.add_flag("--ci-bin", ci_bin, "The physics test's bin (100 x 140 mm, 40 mm stroke, window from 10 mm) instead of the small bin (100 x 330 mm, 200 mm stroke)");
  app.add_option("--seeds", bin.seeds, "LIGGGHTS deposition seeds (1..5); the prediction runs the model at the same seeds")
      ->check(CLI::Range(1, 5))
      ->capture_default_str();
  app.add_option("--jobs", bin.jobs, "Runs at once (LIGGGHTS processes; cases of one evaluation)")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--max-evaluations", max_evaluations, "Objective evaluations per fit")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--model-seeds", model_seeds, "Deposition seeds each built-in case of the fit runs at")->check(CLI::PositiveNumber)->capture_default_str();
  app.add_option("--window-begin-mm", window_begin_mm, "Start of the statistics window (it ends with the stroke; default 10 mm with --ci-bin)")
      ->capture_default_str();
  app.add_option("--out", out_dir, "Working directory (LIGGGHTS runs, soils, run cache)")->capture_default_str();
  app.add_option("--recordings", recordings_dir, "Use the LIGGGHTS recordings of an earlier run in this directory instead of running LIGGGHTS")
      ->check(CLI::ExistingDirectory);
  app.add_flag("--single-layer", single_layer, "Also fit one layer at the shallowest depth and predict every depth with it");
  std::string& json_target = cli::addJsonOption(app);
  app.callback([&] {
    if (!app.count("--window-begin-mm")) window_begin_mm = ci_bin ? campaign::test::kCiBinWindowBeginMm : campaign::test::kSmallBinWindowBeginMm;
    if (!ci_bin) {
      const int seeds = bin.seeds, jobs = bin.jobs;
      bin = campaign::test::smallBin();
      bin.seeds = seeds, bin.jobs = jobs;
    }
    const fs::path out(out_dir);
    fs::create_directories(out);
    if (!std::getenv("DEMFEM_SOIL_DIR") && ::setenv("DEMFEM_SOIL_DIR", (out / "soil").c_str(), 1) != 0)
      throw std::runtime_error("cannot set DEMFEM_SOIL_DIR to " + (out / "soil").string());
    const auto deck = deckVariables();
    const double load_before = bench::loadAverage();
    const auto start = Clock::now();
    const double cpu_start = bench::cpuSeconds();
    std::vector<fs::path> files;
    if (recordings_dir.empty()) {
      std::fprintf(stderr, "LIGGGHTS: %d depositions, %zu drags\n", bin.seeds, bin.depths_mm.size() * static_cast<std::size_t>(bin.seeds));
      files = campaign::test::runLayeredBin(bin, out / "liggghts");
    } else {
      files.push_back(recordings_dir);
    }
    const double liggghts_s = bench::secondsSince(start), liggghts_cpu_s = bench::cpuSeconds() - cpu_start;
    const auto recordings = analysis::readRecordings(files);
    auto options = campaign::test::layeredSoilOptions(bin, window_begin_mm, max_evaluations, out / "runs", model_seeds);
    options.on_progress = [](const campaign::CalibrationProgress& p) {
      std::fprintf(stderr, "fit: evaluation %d/%d, best chi2 %.4g, %.0f s elapsed, about %.0f s left in this fit\n", p.evaluation, p.max_evaluations,
                   p.best_chi2, p.elapsed_s, p.eta_s);
    };
    std::fprintf(stderr, "calibrating (at most %d evaluations per fit)\n", max_evaluations);
    const std::size_t runs_before = cachedRuns(options.cache_dir);
    const auto t = Clock::now();
    const double cpu_t = bench::cpuSeconds();
    const auto o = campaign::test::runLayeredSoil(bin, recordings, options, single_layer);
    const double model_s = bench::secondsSince(t), model_cpu_s = bench::cpuSeconds() - cpu_t;
    const std::size_t runs = cachedRuns(options.cache_dir) - runs_before;
    const double load_after = bench::loadAverage();

    const auto layered = campaign::test::builtinStudy(bin, campaign::test::fixtureData("layered_bin.json"));
    std::FILE* const table = cli::textStream(json_target);
    std::fprintf(table, "--preset layered-soil (two layers; deck: tests/campaign/data/liggghts_layered_bin/materials.in)\n");
    nlohmann::json doc = {{"stroke_mm", bin.stroke_m * 1000},
                          {"bin_mm", {bin.width_m * 1000, bin.length_m * 1000, bin.fill_m * 1000}},
                          {"depths_mm", bin.depths_mm},
                          {"liggghts_seeds", bin.seeds},
                          {"window_begin_mm", window_begin_mm},
                          {"max_evaluations", max_evaluations},
                          {"model_seeds", model_seeds},
                          {"jobs", bin.jobs},
                          {"layered_stages", stagesJson(o.layered, layered, &deck, table)}};
    if (o.single) {
      std::fprintf(table, "one layer fitted at the shallowest depth (no single true value: the deck has two layers)\n");
      doc["single_layer_stages"] = stagesJson(*o.single, campaign::test::singleLayerStudy(bin, std::nullopt), nullptr, table);
    }
    nlohmann::json depths = nlohmann::json::array();
    std::fprintf(table, "%-8s %22s %22s %22s\n", "depth", "LIGGGHTS draught (N)", "two layers (N)", o.single ? "one layer (N)" : "");
    for (const auto& d : o.depths) {
      std::fprintf(table, "%5.0f mm %14.3f +- %5.3f %14.3f +- %5.3f", d.depth_mm, d.liggghts.mean_N, d.liggghts.sd_N, d.calibrated.mean_N, d.calibrated.sd_N);
      nlohmann::json row = {{"depth_mm", d.depth_mm}, {"liggghts", seedJson(d.liggghts)}, {"calibrated", seedJson(d.calibrated)}};
      if (d.single_layer) {
        std::fprintf(table, " %14.3f +- %5.3f", d.single_layer->mean_N, d.single_layer->sd_N);
        row["single_layer"] = seedJson(*d.single_layer);
      }
      std::fprintf(table, "\n");
      depths.push_back(row);
    }
    std::fprintf(table, "%-52s %10s %12s %12s\n", "step", "runs", "wall (s)", "CPU (s)");
    std::fprintf(table, "%-52s %10d %12.0f %12.0f\n", "LIGGGHTS fixture (depositions + drags)", recordings_dir.empty() ? bin.seeds * static_cast<int>(1 + bin.depths_mm.size()) : 0, liggghts_s,
                liggghts_cpu_s);
    std::fprintf(table, "%-52s %10s %12.0f %12s\n", "  calibration + prediction (two layers)", "", o.layered_wall_s, "");
    if (o.single) std::fprintf(table, "%-52s %10s %12.0f %12s\n", "  single layer fit + prediction", "", o.single_wall_s, "");
    std::fprintf(table, "%-52s %10zu %12.0f %12.0f\n", "built-in model runs (all of the above)", runs, model_s, model_cpu_s);
    std::fprintf(table, "%-52s %10s %12.0f %12.0f\n", "whole benchmark", "", bench::secondsSince(start), bench::cpuSeconds() - cpu_start);
    std::fprintf(table, "load average (1 min): %.2f before, %.2f after\n", load_before, load_after);
    doc["depths"] = depths;
    doc["liggghts_wall_s"] = liggghts_s;
    doc["liggghts_cpu_s"] = liggghts_cpu_s;
    doc["layered_calibration_wall_s"] = o.layered_wall_s;
    if (o.single) doc["single_layer_wall_s"] = o.single_wall_s;
    doc["model_runs"] = runs;
    doc["model_wall_s"] = model_s;
    doc["model_cpu_s"] = model_cpu_s;
    doc["total_wall_s"] = bench::secondsSince(start);
    doc["total_cpu_s"] = bench::cpuSeconds() - cpu_start;
    doc["load_average_before"] = load_before;
    doc["load_average_after"] = load_after;
    cli::writeJson(json_target, doc);
  });
  return cli::runApp(app, argc, argv);
}

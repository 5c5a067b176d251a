// campaign's soil-bin model: a coupled run (fem::CoupledDriver, built-in DEM in-process) of the case
// a recording names, evaluated like a measured run; repeated through the run cache.
#include "weight_drop_fixture.hpp"

#include "demfem/analysis/synthetic.hpp"
#include "demfem/adapter/settled_soil.hpp"
#include "demfem/campaign/calibration.hpp"
#include "demfem/campaign/model.hpp"
#include "demfem/study/study.hpp"

#include <catch2/catch.hpp>

#include <cstdlib>
#include <set>
#include <string>
#include <vector>

using namespace demfem;

TEST_CASE("a soil-bin recording runs the study at the recording's depth and is scored on its window", "[campaign][physics]") {
  const campaign::test::TempDir dir("soil");
  const std::filesystem::path study_file = std::filesystem::path(DEMFEM_SOURCE_DIR) / "tests/campaign/data/tiny_bin.json";
  std::ifstream in(study_file);
  const auto study = nlohmann::ordered_json::parse(in);
  // A "measured" run at 12 mm (the study says 15 mm): 30 mm stroke, window 5-25 mm.
  analysis::SoilBinTruth truth;
  truth.tool = "tool", truth.depth_mm = 12, truth.stroke_mm = 30, truth.ramp_mm = 3, truth.wall_start_mm = 28;
  truth.velocity_mm_s = 36.14, truth.force_N = 2.0, truth.deformation_mm = 0.02;
  analysis::writeSyntheticRecording(analysis::makeSoilBinRecording(truth, analysis::RecordingFormat::Calibrated), dir.path() / "m.csv");
  const auto recordings = analysis::readRecordings({dir.path() / "m.csv"});
  campaign::CalibrationOptions options;
  options.objective.analysis.evaluation.window_begin_mm = 5;
  options.objective.analysis.evaluation.window_end_mm = 25;
  options.cache_dir = dir.path() / "runs";
  campaign::SoilBinModel model;
  std::vector<analysis::Recording> runs;
  const auto residuals = campaign::predict(study, study_file.string(), recordings, model, options, &runs);
  REQUIRE(runs.size() == 1);
  CHECK(runs[0].key.depth_mm == 12);
  CHECK(runs[0].displacement_mm.back() == Approx(30).margin(0.5));
  REQUIRE(residuals.size() == 4);  // window mean and spread of force and deformation
  CHECK(residuals[0].quantity == "window_mean_force_N");
  CHECK(residuals[0].simulated > 0);  // the soil pushes the tool against its travel
  // The same prediction again comes from the run cache: identical numbers without a run.
  const auto t = std::chrono::steady_clock::now();
  const auto again = campaign::predict(study, study_file.string(), recordings, model, options);
  CHECK(std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count() < 2.0);
  CHECK(again[0].simulated == residuals[0].simulated);
}

namespace {

// Points the soil cache at `dir` for the test's lifetime.
class SoilDirectory {
 public:
  explicit SoilDirectory(const std::filesystem::path& dir) : had_previous_(std::getenv("DEMFEM_SOIL_DIR") != nullptr) {
    if (had_previous_) previous_ = std::getenv("DEMFEM_SOIL_DIR");
    ::setenv("DEMFEM_SOIL_DIR", dir.c_str(), 1);
  }
  ~SoilDirectory() {
    if (had_previous_)
      ::setenv("DEMFEM_SOIL_DIR", previous_.c_str(), 1);
    else
      ::unsetenv("DEMFEM_SOIL_DIR");
  }
  SoilDirectory(const SoilDirectory&) = delete;
  SoilDirectory& operator=(const SoilDirectory&) = delete;

 private:
  bool had_previous_;
  std::string previous_;
};

}  // namespace

TEST_CASE("the soil-bin model refuses an unsettled soil, naming the study, the file and the reason, unless allowed", "[campaign]") {
  const campaign::test::TempDir dir("unsettled");
  const SoilDirectory soil_dir(dir.path() / "soil");
  const auto study = study::loadStudy(std::filesystem::path(DEMFEM_SOURCE_DIR) / "tests/campaign/data/tiny_bin.json");
  // A soil whose last settling phase hit its time cap: a few grains on the floor.
  adapter::SettledSoil soil;
  soil.soil_hash = study::soilHash(study);
  soil.seed = study.soil.deposition_seed;
  soil.settling = {2.5e-6, study.soil.settle_kinetic_energy_J, 5, 1, true, 7.5, 0.0, 0.0};
  for (int i = 0; i < 4; ++i)
    soil.particles.push_back({{0.02 + 0.012 * i, study.soil.diameter_max_m / 2, 0.02}, study.soil.diameter_max_m / 2, 0});
  const auto file = adapter::settledSoilFile(study, dir.path() / "soil");
  adapter::writeSettledSoil(file, soil);
  CHECK_THROWS_WITH(campaign::SoilBinModel().prepare({study}, {}),
                    Catch::Contains("study '" + study.name + "'") && Catch::Contains(file.string()) &&
                        Catch::Contains("final settling phase hit its time cap") && Catch::Contains("--allow-unsettled-soil"));
  CHECK_NOTHROW(campaign::SoilBinModel(campaign::SoilForce::LoadCell, std::nullopt, true).prepare({study}, {}));
}

TEST_CASE("a shared packing is deposited once per seed, reported under the name of the study it is for", "[campaign]") {
  const campaign::test::TempDir dir("packing");
  const SoilDirectory soil_dir(dir.path() / "soil");
  const auto packing = study::loadStudy(std::filesystem::path(DEMFEM_SOURCE_DIR) / "tests/campaign/data/tiny_bin.json");
  // Two studies at seed 7 that differ from the packing study in their step only: the packing's
  // deposition at seed 7, made once, serves both (as the convergence bench's fractions share it).
  std::vector<study::Study> studies(2, packing);
  for (int i = 0; i < 2; ++i) {
    studies[i].name = "tiny_bin_step" + std::to_string(i) + "_seed7";
    studies[i].soil.deposition_seed = 7;
    studies[i].dem.dt_fraction = packing.dem.dt_fraction / (i + 2);
  }
  std::set<std::string> reported;
  campaign::SoilBinModel(campaign::SoilForce::LoadCell, packing).prepare(studies, [&](const std::string& name, double, const std::string&) {
    reported.insert(name);
  });
  // One deposition (a second would be reported under the second study's name), named for the study
  // that needed it: not the packing study's name, the same for every seed.
  CHECK(reported == std::set<std::string>{studies[0].name});
  // Both relabelled soils hold the one packing, each under its own study's hash.
  const auto first = adapter::readSettledSoil(adapter::settledSoilFile(studies[0], dir.path() / "soil"), studies[0]);
  const auto second = adapter::readSettledSoil(adapter::settledSoilFile(studies[1], dir.path() / "soil"), studies[1]);
  CHECK(first.soil_hash == study::soilHash(studies[0]));
  CHECK(second.soil_hash == study::soilHash(studies[1]));
  REQUIRE(first.particles.size() == second.particles.size());
  REQUIRE(!first.particles.empty());
  for (std::size_t i = 0; i < first.particles.size(); ++i) CHECK(first.particles[i].x_m == second.particles[i].x_m);
}

// Calibration against recordings made by the project's own model (direct integration, known E and
// alpha, DAQ noise and quantisation): parameters recovered, non-identification reported, runs cached.
#include "weight_drop_fixture.hpp"

#include "demfem/campaign/calibration.hpp"

#include <catch2/catch.hpp>

#include <cmath>

using namespace demfem;
using campaign::test::TempDir;

namespace {

std::vector<analysis::Recording> recordings(const TempDir& dir, const std::vector<double>& masses, const campaign::test::TruthSettings& truth) {
  campaign::test::writeRecordings(dir.path(), masses, 2, truth);
  return analysis::readRecordings({dir.path()});
}

campaign::CalibrationOptions quickOptions(const std::filesystem::path& cache) {
  campaign::CalibrationOptions o;
  o.starts = 2;
  o.cache_dir = cache;
  return o;
}

}  // namespace

TEST_CASE("the weight-drop preset recovers E within 1 % and alpha within 5 % from both weights", "[campaign]") {
  const TempDir dir("preset");
  const campaign::test::TruthSettings truth;  // E 4.5 GPa, alpha 0.8 ms; the study says 4.06 GPa, 0.55 ms
  const auto recs = recordings(dir, {0.05, 0.1}, truth);
  const auto study = campaign::test::fixtureStudyJson();
  const auto stages = campaign::weightDropPreset(study, recs);
  campaign::WeightDropModel model;
  const auto options = quickOptions(dir.path() / "cache");
  const campaign::StagedCalibration c =
      campaign::calibrateStages(study, campaign::test::fixtureStudyPath().string(), recs, stages, model, options);
  REQUIRE(c.results.size() == 1);
  const auto& r = c.results.front();
  REQUIRE(r.parameters.size() == 2);
  REQUIRE(r.parameters[0].value);
  REQUIRE(r.parameters[1].value);
  CHECK(*r.parameters[0].value == Approx(truth.E_Pa).epsilon(0.01));
  CHECK(*r.parameters[1].value == Approx(truth.alpha_s).epsilon(0.05));
  CHECK(r.parameters[0].identified);
  CHECK(r.parameters[1].identified);
  CHECK(r.chi2 < r.initial_chi2);
  CHECK(r.minima.size() == 1);
  // The calibrated study is a valid study carrying the fitted values.
  const study::Study calibrated = study::parseStudy(c.calibrated_study.dump(), campaign::test::fixtureStudyPath().string());
  CHECK(calibrated.tools[0].fem.youngs_Pa == Approx(*r.parameters[0].value));
  // A repeated calibration reuses every run from the cache.
  campaign::WeightDropModel fresh;
  const auto again = campaign::calibrateStages(study, campaign::test::fixtureStudyPath().string(), recs, stages, fresh, options);
  CHECK(again.results.front().model_runs == 0);
  CHECK(again.results.front().cache_hits > 0);
  CHECK(*again.results.front().parameters[0].value == Approx(*r.parameters[0].value).epsilon(1e-12));
}

TEST_CASE("stiffness- and mass-proportional damping from one weight are reported unidentified", "[campaign]") {
  const TempDir dir("unidentified");
  const auto recs = recordings(dir, {0.05}, {});
  campaign::CalibrationProblem problem{campaign::test::fixtureStudyJson(), campaign::test::fixtureStudyPath().string(), recs,
                                       {campaign::parseParameterSpec("/tools/0/fem/E_Pa=2e9:8e9:log"),
                                        campaign::parseParameterSpec("/tools/0/fem/alpha_s=0:2e-3"),
                                        campaign::parseParameterSpec("/tools/0/fem/beta_per_s=0:50")}};
  campaign::WeightDropModel model;
  const auto r = campaign::calibrate(problem, model, quickOptions({}));
  // One weight rings at one frequency: its damping ratio fixes alpha w / 2 + beta / (2 w), not both
  // (measured: alpha 0.80 +- 0.43 ms, beta 0.001 +- 19 1/s; E 4.499 +- 0.004 GPa).
  CHECK(r.parameters[0].identified);
  CHECK(!r.parameters[1].identified);
  CHECK(!r.parameters[1].value);
  CHECK(!r.parameters[2].identified);
  CHECK(!r.parameters[2].value);
}

TEST_CASE("a noisy objective widens each sigma by the model's seed scatter taken as the repeats'", "[campaign]") {
  const TempDir dir("widened");
  const auto recs = recordings(dir, {0.05}, {});  // two repeats with their own noise
  const auto study = campaign::test::fixtureStudyJson();
  const std::string origin = campaign::test::fixtureStudyPath().string();
  campaign::WeightDropModel model;
  campaign::CalibrationOptions options = quickOptions({});
  const auto measured = campaign::quantities(recs, options.objective, false);
  const auto sigmas = [&](campaign::ObjectiveKind kind, int model_seeds, bool like_repeats) {
    options.kind = kind, options.model_seeds = model_seeds, options.model_scatters_like_repeats = like_repeats;
    std::vector<double> out;
    for (const auto& r : campaign::predict(study, origin, recs, model, options)) out.push_back(r.sigma);
    return out;
  };
  const auto smooth = sigmas(campaign::ObjectiveKind::Smooth, 1, true);
  const auto one_seed = sigmas(campaign::ObjectiveKind::Noisy, 1, true);
  const auto four_seeds = sigmas(campaign::ObjectiveKind::Noisy, 4, true);
  const auto measured_scatter = sigmas(campaign::ObjectiveKind::Noisy, 1, false);  // diagnose measures it instead
  REQUIRE(smooth.size() == measured.size());
  for (std::size_t i = 0; i < measured.size(); ++i) {
    INFO(measured[i].name);
    CHECK(measured[i].repeat_sd > 0);
    CHECK(smooth[i] == measured[i].sigma);
    CHECK(measured_scatter[i] == measured[i].sigma);
    CHECK(one_seed[i] == Approx(std::hypot(measured[i].sigma, measured[i].repeat_sd)).epsilon(1e-12));
    CHECK(four_seeds[i] == Approx(std::hypot(measured[i].sigma, measured[i].repeat_sd / 2)).epsilon(1e-12));
  }
}

TEST_CASE("an objective restricted to some quantities fits and scores those only, an unknown name is an error naming it", "[campaign]") {
  const TempDir dir("restricted");
  const auto recs = recordings(dir, {0.05}, {});
  campaign::ObjectiveSettings all;
  campaign::ObjectiveSettings some;
  some.only_quantities = {"frequency_Hz", "step_force_N"};
  const auto every = campaign::quantities(recs, all, false);
  const auto kept = campaign::quantities(recs, some, false);
  REQUIRE(every.size() == 4);
  REQUIRE(kept.size() == 2);
  CHECK(kept[0].name == "step_force_N");  // listed in quantityNames() order, not the request's
  CHECK(kept[1].name == "frequency_Hz");
  CHECK(kept[0].value == every[0].value);
  CHECK(kept[1].sigma == every[2].sigma);
  campaign::WeightDropModel model;
  campaign::CalibrationOptions options = quickOptions({});
  options.objective = some;
  const auto residuals = campaign::predict(campaign::test::fixtureStudyJson(), campaign::test::fixtureStudyPath().string(), recs, model, options);
  REQUIRE(residuals.size() == 2);
  CHECK(residuals[1].quantity == "frequency_Hz");
  some.only_quantities.push_back("window_mean_force");
  try {
    campaign::quantities(recs, some, false);
    FAIL("an unknown quantity name was accepted");
  } catch (const campaign::ArgumentError& e) {
    CHECK_THAT(e.what(), Catch::Contains("'window_mean_force' is not a quantity") && Catch::Contains("window_mean_force_N"));
  }
}

TEST_CASE("bad --fit arguments are errors naming the argument", "[campaign]") {
  const auto study = campaign::test::fixtureStudyJson();
  const std::string origin = campaign::test::fixtureStudyPath().string();
  const auto message = [&](const std::string& arg) {
    try {
      campaign::validateParameters(study, origin, {campaign::parseParameterSpec(arg)});
    } catch (const campaign::ArgumentError& e) {
      return std::string(e.what());
    }
    return std::string("no error");
  };
  using Catch::Matchers::Contains;
  CHECK_THAT(message("/tools/0/fem/E_Pa"), Contains("--fit '/tools/0/fem/E_Pa'") && Contains("PATH=LO:HI"));
  CHECK_THAT(message("/tools/0/fem/E_Pa=3e9:x"), Contains("--fit '/tools/0/fem/E_Pa=3e9:x'") && Contains("HI 'x'"));
  CHECK_THAT(message("/tools/0/fem/E_Pa=5e9:3e9"), Contains("LO must be smaller than HI"));
  CHECK_THAT(message("/tools/0/fem/E_Pa=0:3e9:log"), Contains("log parameter needs LO > 0"));
  CHECK_THAT(message("/tools/0/fem/E_Pa=1:2:lin"), Contains("third field must be 'log'"));
  CHECK_THAT(message("/tools/0/fem/Young=1:2"), Contains("--fit '/tools/0/fem/Young=1:2'") && Contains("no value at /tools/0/fem/Young"));
  CHECK_THAT(message("/tools/0/name=1:2"), Contains("/tools/0/name is not a number"));
  CHECK_THAT(message("/tools/0/fem/nu=0.1:0.7"), Contains("--fit '/tools/0/fem/nu=0.1:0.7'") && Contains("upper bound 0.7") &&
                                                      Contains("/tools/0/fem/nu"));
  CHECK_THAT(message("/tools/0/fem/E_Pa=-1e9:3e9"), Contains("lower bound -1e+09"));
  CHECK(message("/tools/0/fem/E_Pa=3e9:5e9:log") == "no error");
}

TEST_CASE("recordings of a case the study cannot run are an error naming the case", "[campaign]") {
  const TempDir dir("soil_case");
  analysis::SoilBinTruth soil;
  soil.tool = "strip";
  analysis::writeSyntheticRecording(analysis::makeSoilBinRecording(soil, analysis::RecordingFormat::Calibrated), dir.path() / "soil.csv");
  campaign::CalibrationProblem problem{campaign::test::fixtureStudyJson(), campaign::test::fixtureStudyPath().string(),
                                       analysis::readRecordings({dir.path()}),
                                       {campaign::parseParameterSpec("/tools/0/fem/E_Pa=2e9:8e9:log")}};
  campaign::WeightDropModel model;
  CHECK_THROWS_WITH(campaign::calibrate(problem, model, quickOptions({})),
                    Catch::Matchers::Contains("strip, 30 mm depth") && Catch::Matchers::Contains("needs a coupled or dem-only study"));
}

TEST_CASE("the layered-soil preset fits, depth by depth, the deepest layer the tool reaches", "[campaign]") {
  const TempDir dir("layered");
  for (double depth : {25.0, 8.0, 15.0}) {
    analysis::SoilBinTruth soil;
    soil.tool = "tool", soil.depth_mm = depth;
    analysis::writeSyntheticRecording(analysis::makeSoilBinRecording(soil, analysis::RecordingFormat::Calibrated),
                                      dir.path() / ("d" + std::to_string(static_cast<int>(depth)) + ".csv"));
  }
  const std::filesystem::path file = std::filesystem::path(DEMFEM_SOURCE_DIR) / "tests/campaign/data/tiny_bin.json";
  std::ifstream in(file);
  const auto study = nlohmann::ordered_json::parse(in);
  const auto stages = campaign::layeredSoilPreset(study, file.string(), analysis::readRecordings({dir.path()}));
  // Layers: layer1 0-10 mm, layer2 10-30 mm. 8 mm reaches layer1, 15 mm layer2; at 25 mm layer2
  // is still the deepest and was fitted already.
  REQUIRE(stages.size() == 2);
  CHECK(stages[0].cases.size() == 1);
  CHECK(stages[0].cases[0].depth_mm == 8);
  CHECK(stages[1].cases[0].depth_mm == 15);
  REQUIRE(stages[0].parameters.size() == 2);
  CHECK(study.at(nlohmann::ordered_json::json_pointer(stages[0].parameters[0].pointer.substr(0, stages[0].parameters[0].pointer.rfind('/')) +
                                                      "/materials")) == nlohmann::ordered_json({"layer1", "layer1"}));
  CHECK(stages[0].parameters[0].label() == "static_friction");
  CHECK(stages[0].parameters[1].label() == "rolling_friction");
  CHECK(study.at(nlohmann::ordered_json::json_pointer(stages[1].parameters[0].pointer.substr(0, stages[1].parameters[0].pointer.rfind('/')) +
                                                      "/materials")) == nlohmann::ordered_json({"layer2", "layer2"}));
  CHECK_THROWS_WITH(campaign::weightDropPreset(study, analysis::readRecordings({dir.path()})), Catch::Matchers::Contains("not weight-drop"));
}

TEST_CASE("a soil case's stroke is cut to the window's end when the study's is longer, never lengthened", "[campaign]") {
  const std::filesystem::path file = std::filesystem::path(DEMFEM_SOURCE_DIR) / "tests/campaign/data/tiny_bin.json";
  std::ifstream in(file);
  const auto study = nlohmann::ordered_json::parse(in);  // stroke 30 mm
  const analysis::CaseKey key{analysis::CaseKind::SoilBin, "tool", 12, 0};
  CHECK(campaign::caseStudy(study, file.string(), key, 20.0).tools[0].motion.stroke_m == Approx(0.020).epsilon(1e-12));
  CHECK(campaign::caseStudy(study, file.string(), key, 45.0).tools[0].motion.stroke_m == Approx(0.030).epsilon(1e-12));
  CHECK(campaign::caseStudy(study, file.string(), key).tools[0].motion.stroke_m == Approx(0.030).epsilon(1e-12));
  CHECK(campaign::caseStudy(study, file.string(), key, 20.0).tools[0].motion.depth_m == Approx(0.012).epsilon(1e-12));
}

TEST_CASE("the draught model refuses a deformable tool, naming it, before any DEM work", "[campaign]") {
  const std::filesystem::path file = std::filesystem::path(DEMFEM_SOURCE_DIR) / "tests/campaign/data/tiny_bin.json";
  std::ifstream in(file);
  const auto study = nlohmann::ordered_json::parse(in);  // coupled, deformable PMMA tool
  const analysis::CaseKey key{analysis::CaseKind::SoilBin, "tool", 12, 0};
  campaign::SoilBinModel model(campaign::SoilForce::Draught);
  CHECK(model.name() != campaign::SoilBinModel().name());  // the run cache keeps the two forces apart
  CHECK_THROWS_AS(model.run(campaign::caseStudy(study, file.string(), key), key, {}), campaign::ArgumentError);
  CHECK_THROWS_WITH(model.run(campaign::caseStudy(study, file.string(), key), key, {}),
                    Catch::Matchers::Contains("tool 'tool' is deformable") && Catch::Matchers::Contains("dem-only"));
}

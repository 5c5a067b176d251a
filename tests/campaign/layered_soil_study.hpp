// The soil study of the layered-bin fixture (liggghts_layered_bin.hpp), shared by the physics test
// and the benchmark (docs/calibration.md, "Soil against LIGGGHTS"; docs/diagnosis.md):
//  1. `--preset layered-soil` of the two-layer built-in study on every recording, then the
//     calibrated study's prediction of every depth;
//  2. optionally the single-layer built-in study fitted (the same preset: one stage) on the
//     shallowest depth's recordings only, then its prediction of every depth;
//  and `demfem diagnose` of the recordings with a single-layer study (diagnoseSingleLayer).
// The built-in model records the draught of the rigid plate (campaign::SoilForce::Draught), like
// the deck, and packs its soils from the deposition of the study each step starts from (shared
// packing, campaign/model.hpp). Per depth: the LIGGGHTS seeds' window means (mean, sample standard deviation) against
// both predictions at the same seeds. Wall times measured around each step.
#pragma once

#include "liggghts_layered_bin.hpp"

#include "demfem/campaign/calibration.hpp"
#include "demfem/campaign/diagnose.hpp"

#include <chrono>
#include <cmath>
#include <map>
#include <optional>

namespace demfem::campaign::test {

// Window mean of the draught over the seeds (the same seeds 1..n on both engines): mean and sample
// standard deviation of the seeds whose run gave a draught, and how many runs failed (a DEM
// blow-up or the overlap guard: no draught, left out of the mean).
struct SeedMean {
  double mean_N = 0, sd_N = 0;
  int failed_runs = 0;
};

struct DepthFigures {
  double depth_mm = 0;
  SeedMean liggghts;
  SeedMean calibrated;                   // two layers, --preset layered-soil
  std::optional<SeedMean> single_layer;  // one layer fitted at the shallowest depth (when fitted)
};

struct LayeredSoilOutcome {
  std::vector<DepthFigures> depths;  // ascending
  StagedCalibration layered;
  std::optional<StagedCalibration> single;
  double layered_wall_s = 0, single_wall_s = 0;
};

inline std::filesystem::path fixtureData(const std::string& name) {
  return std::filesystem::path(DEMFEM_SOURCE_DIR) / "tests/campaign/data" / name;
}

// The objective and optimiser of the soil runs: window from `window_begin_mm` to the stroke's end,
// no deformation (rigid), one start, the noisy-objective steps, the stroke ending with the window,
// each case at `model_seeds` deposition seeds.
inline CalibrationOptions layeredSoilOptions(const LayeredBin& bin, double window_begin_mm, int max_evaluations,
                                             const std::filesystem::path& cache_dir, int model_seeds) {
  CalibrationOptions o;
  o.objective.analysis.evaluation.window_begin_mm = window_begin_mm;
  o.objective.analysis.evaluation.window_end_mm = bin.stroke_m * 1000;
  o.objective.soil_deformation = false;
  o.kind = ObjectiveKind::Noisy;
  o.starts = 1;
  o.max_evaluations = max_evaluations;
  useNoisySteps(o);
  o.stroke_ends_with_window = true;
  o.jobs = bin.jobs;
  o.model_seeds = model_seeds;
  o.cache_dir = cache_dir;
  return o;
}

namespace detail {

inline SeedMean seedMean(const std::vector<double>& values) {
  SeedMean m;
  for (double v : values) m.mean_N += v / static_cast<double>(values.size());
  double ss = 0;
  for (double v : values) ss += (v - m.mean_N) * (v - m.mean_N);
  m.sd_N = values.size() > 1 ? std::sqrt(ss / static_cast<double>(values.size() - 1)) : 0.0;
  return m;
}

// The study's prediction of every depth at deposition seeds 1..seeds, per depth.
inline std::map<double, SeedMean> predictSeeds(const nlohmann::ordered_json& study, const std::string& origin,
                                               const std::vector<analysis::Recording>& recordings, Model& model,
                                               const CalibrationOptions& options, int seeds) {
  std::map<double, std::vector<double>> values, failed;  // failed: one entry per recording of a failed run
  for (int seed = 1; seed <= seeds; ++seed) {
    nlohmann::ordered_json s = study;
    s["soil"]["deposition"]["seed"] = seed;
    CalibrationOptions one_seed = options;  // the fits' runs at these seeds come from the run cache
    one_seed.model_seeds = 1;
    for (const auto& r : predict(s, origin, recordings, model, one_seed))
      if (r.quantity == "window_mean_force_N") (r.missing ? failed[r.key.depth_mm] : values[r.key.depth_mm]).push_back(r.simulated);
  }
  std::map<double, SeedMean> out;
  for (const auto& [depth, v] : values) out[depth] = seedMean(v);
  for (const auto& [depth, f] : failed) out[depth].failed_runs = static_cast<int>(f.size());
  return out;
}

inline double secondsSince(std::chrono::steady_clock::time_point t) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t).count();
}

}  // namespace detail

// The single-layer built-in study of `bin`, its particle friction set to `static_friction` when given.
inline nlohmann::ordered_json singleLayerStudy(const LayeredBin& bin, std::optional<double> static_friction) {
  auto s = builtinStudy(bin, fixtureData("single_layer_bin.json"));
  if (static_friction) s["soil"]["interactions"][0]["static_friction"] = *static_friction;  // the soil-soil pair
  return s;
}

// `demfem diagnose` of `recordings` with `single`, a single-layer study of `bin`. The soil is
// prepared (deposited) at the fixture study's friction whatever the study's: the deck's preparation
// (deposit.in).
inline Diagnosis diagnoseSingleLayer(const LayeredBin& bin, const std::vector<analysis::Recording>& recordings,
                                     const DiagnosisSettings& settings, const nlohmann::ordered_json& single) {
  const std::string single_file = fixtureData("single_layer_bin.json").string();
  SoilBinModel model(SoilForce::Draught, study::parseStudy(singleLayerStudy(bin, std::nullopt).dump(), single_file));
  return diagnose(single, single_file, recordings, model, settings);
}

inline LayeredSoilOutcome runLayeredSoil(const LayeredBin& bin, const std::vector<analysis::Recording>& recordings,
                                         const CalibrationOptions& options, bool fit_single_layer) {
  LayeredSoilOutcome out;
  const auto modelOf = [](const nlohmann::ordered_json& study, const std::string& origin) {
    return SoilBinModel(SoilForce::Draught, study::parseStudy(study.dump(), origin));
  };
  std::map<double, std::vector<double>> seeds;
  for (const auto& r : recordings)
    for (const auto& q : quantities({r}, options.objective, false))
      if (q.name == "window_mean_force_N") seeds[r.key.depth_mm].push_back(q.value);

  const std::string layered_file = fixtureData("layered_bin.json").string();
  const auto layered = builtinStudy(bin, layered_file);
  SoilBinModel layered_model = modelOf(layered, layered_file);
  auto t = std::chrono::steady_clock::now();
  out.layered = calibrateStages(layered, layered_file, recordings, layeredSoilPreset(layered, layered_file, recordings), layered_model,
                                options);
  const auto calibrated = detail::predictSeeds(out.layered.calibrated_study, layered_file, recordings, layered_model, options, bin.seeds);
  out.layered_wall_s = detail::secondsSince(t);

  std::map<double, SeedMean> single_layer;
  if (fit_single_layer) {
    const std::string single_file = fixtureData("single_layer_bin.json").string();
    const auto single = singleLayerStudy(bin, std::nullopt);
    std::vector<analysis::Recording> shallow;
    for (const auto& r : recordings)
      if (r.key.depth_mm == seeds.begin()->first) shallow.push_back(r);
    SoilBinModel single_model = modelOf(single, single_file);
    t = std::chrono::steady_clock::now();
    out.single = calibrateStages(single, single_file, shallow, layeredSoilPreset(single, single_file, shallow), single_model, options);
    single_layer = detail::predictSeeds(out.single->calibrated_study, single_file, recordings, single_model, options, bin.seeds);
    out.single_wall_s = detail::secondsSince(t);
  }
  for (const auto& [depth, values] : seeds) {
    DepthFigures f{depth, detail::seedMean(values), calibrated.at(depth), std::nullopt};
    if (fit_single_layer) f.single_layer = single_layer.at(depth);
    out.depths.push_back(f);
  }
  return out;
}

}  // namespace demfem::campaign::test

// The independent soil fixture of the layered-soil tests and benchmark (docs/calibration.md, "Soil
// against LIGGGHTS"): the hand-written LIGGGHTS input deck tests/campaign/data/liggghts_layered_bin
// run by the `liggghts` executable itself (not through the project's backend), one deposition per
// seed reused by every depth, a rigid plate dragged at each depth, its draught per 1 ms written by
// the deck as a calibrated recording (t_s,force_N,deformation_mm,displacement_mm) to which this
// helper adds the sidecar {"tool", "depth_mm", "repeat" = the seed}.
//
// Contract: units of the deck (SI) in LayeredBin, mm in the file names and sidecars. Runs `jobs`
// LIGGGHTS processes at once. Throws std::runtime_error naming the command (and its log file) when
// the executable is missing or a run fails or writes no recording; nothing is kept half written:
// a run's CSV is only given a sidecar once its process exited with 0.
#pragma once

#include <nlohmann/json.hpp>

#include <unistd.h>

#include <atomic>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace demfem::campaign::test {

// The CI bin by default (docs/calibration.md, "Soil against LIGGGHTS"): 75 mm of soil, the interface
// 30 mm below the fill height, depths 20 mm (two grains of cut, top layer only), 40 and 55 mm (the
// tip 20 mm above the floor), 40 mm of stroke (the window ends before the soil ahead of the plate
// reaches the end wall).
struct LayeredBin {
  double width_m = 0.1, length_m = 0.14, fill_m = 0.075, interface_m = 0.03;  // interface: depth below the fill
  double start_z_m = 0.03, stroke_m = 0.04, velocity_m_s = 0.1, insertion_velocity_m_s = 0.1;
  std::vector<double> depths_mm{20, 40, 55};
  int seeds = 3;  // 1..seeds (at most 5)
  int jobs = 2;
  std::string tool = "plate";  // the tool name of the sidecars (the built-in study's tool)
  // Set: a single-layer deck, this particle-particle friction everywhere (the drag's mu_top,
  // mu_bottom, mu_between); the deposition is the same.
  std::optional<double> uniform_friction;
};

// The small bin of the cost benchmarks (docs/calibration.md, "Cost of a soil calibration"): the CI
// bin 330 mm long (about 2,570 particles) with a 200 mm stroke; statistics window from 50 mm.
inline LayeredBin smallBin() {
  LayeredBin bin;
  bin.length_m = 0.33, bin.stroke_m = 0.2;
  return bin;
}
constexpr double kSmallBinWindowBeginMm = 50;
constexpr double kCiBinWindowBeginMm = 10;  // the CI bin's window: 10 mm to the stroke's end

// The built-in study of `bin` from one of the fixture studies (tests/campaign/data/layered_bin.json,
// single_layer_bin.json): bin, fill, tool plan and the layers' depths set from `bin` (the layers
// keep their materials; two layers are split at the interface, one spans the fill).
inline nlohmann::ordered_json builtinStudy(const LayeredBin& bin, const std::filesystem::path& study_file) {
  std::ifstream in(study_file);
  nlohmann::ordered_json s = nlohmann::ordered_json::parse(in);
  auto& soil = s["soil"];
  soil["bin"]["length_mm"] = bin.length_m * 1000, soil["bin"]["width_mm"] = bin.width_m * 1000;
  soil["fill_height_mm"] = bin.fill_m * 1000;
  auto& layers = soil["layers"];
  layers.back()["bottom_depth_mm"] = bin.fill_m * 1000;
  if (layers.size() == 2) layers[0]["bottom_depth_mm"] = layers[1]["top_depth_mm"] = bin.interface_m * 1000;
  auto& motion = s["tools"][0]["motion"];
  motion["velocity_mm_s"] = bin.velocity_m_s * 1000, motion["insertion_velocity_mm_s"] = bin.insertion_velocity_m_s * 1000;
  motion["stroke_mm"] = bin.stroke_m * 1000, motion["start_z_mm"] = bin.start_z_m * 1000;
  return s;
}

inline std::filesystem::path layeredBinDeck() {
  return std::filesystem::path(DEMFEM_SOURCE_DIR) / "tests/campaign/data/liggghts_layered_bin";
}

namespace detail {

inline std::string num(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", v);
  return buffer;
}

inline void runLiggghts(const std::filesystem::path& dir, const std::string& deck, const std::string& variables,
                        const std::string& log) {
  const std::string command = "cd '" + dir.string() + "' && liggghts -echo none -log none -in '" + (layeredBinDeck() / deck).string() +
                              "' -var deck '" + layeredBinDeck().string() + "' " + variables + " > '" + log + "' 2>&1";
  if (std::system(command.c_str()) != 0)
    throw std::runtime_error("LIGGGHTS run failed: " + command + " (see " + (dir / log).string() + ")");
}

inline std::string frictionVariables(const LayeredBin& bin) {
  if (!bin.uniform_friction) return "";
  const std::string mu = num(*bin.uniform_friction);
  return " -var mu_top " + mu + " -var mu_bottom " + mu + " -var mu_between " + mu;
}

// Runs tasks on `jobs` threads; the first failure is rethrown after all finished.
inline void parallel(const std::vector<std::function<void()>>& tasks, int jobs) {
  std::atomic<std::size_t> next{0};
  std::vector<std::exception_ptr> errors(tasks.size());
  const auto worker = [&] {
    for (std::size_t i; (i = next++) < tasks.size();) try {
        tasks[i]();
      } catch (...) {
        errors[i] = std::current_exception();
      }
  };
  std::vector<std::thread> pool;
  for (int t = 1; t < jobs; ++t) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
}

}  // namespace detail

// Runs the fixture into `dir` (created); returns the recordings (CSV files with sidecars), seed by
// seed, depths ascending.
inline std::vector<std::filesystem::path> runLayeredBin(const LayeredBin& bin, const std::filesystem::path& dir) {
  // LIGGGHTS takes primes above 10000 as seeds: two per deposition seed.
  static constexpr long kPrimes[] = {15485863, 32452843, 49979687, 67867967, 86028121, 104395301, 122949823, 141650939, 160481183, 179424673};
  if (bin.seeds < 1 || bin.seeds > 5) throw std::invalid_argument("LayeredBin: seeds must be 1..5");
  std::filesystem::create_directories(dir);
  const std::string geometry = "-var W " + detail::num(bin.width_m) + " -var L " + detail::num(bin.length_m) + " -var fill " +
                               detail::num(bin.fill_m);
  std::vector<std::function<void()>> depositions, drags;
  std::vector<std::filesystem::path> recordings;
  for (int seed = 1; seed <= bin.seeds; ++seed) {
    const std::string soil = "soil_" + std::to_string(seed) + ".restart";
    depositions.push_back([=] {
      detail::runLiggghts(dir, "deposit.in",
                          geometry + " -var interface " + detail::num(bin.interface_m) + " -var seed_a " + std::to_string(kPrimes[2 * seed - 2]) +
                              " -var seed_b " + std::to_string(kPrimes[2 * seed - 1]) + " -var soil " + soil,
                          "deposit_" + std::to_string(seed) + ".log");
    });
    for (double depth_mm : bin.depths_mm) {
      const std::string stem = "seed" + std::to_string(seed) + "_" + detail::num(depth_mm) + "mm";
      recordings.push_back(dir / (stem + ".csv"));
      drags.push_back([=] {
        detail::runLiggghts(dir, "drag.in",
                            geometry + " -var soil " + soil + " -var depth " + detail::num(depth_mm / 1000) + " -var start_z " +
                                detail::num(bin.start_z_m) + " -var stroke " + detail::num(bin.stroke_m) + " -var v " +
                                detail::num(bin.velocity_m_s) + " -var v_insert " + detail::num(bin.insertion_velocity_m_s) +
                                detail::frictionVariables(bin) + " -var csv " + stem + ".csv",
                            stem + ".log");
        std::ofstream sidecar(dir / (stem + ".json"));
        sidecar << nlohmann::json{{"tool", bin.tool}, {"depth_mm", depth_mm}, {"repeat", seed}}.dump(2) << "\n";
        sidecar.close();
        if (!sidecar) throw std::runtime_error("cannot write " + (dir / (stem + ".json")).string());
      });
    }
  }
  detail::parallel(depositions, bin.jobs);
  detail::parallel(drags, bin.jobs);
  return recordings;
}

namespace detail {

// FNV-1a of the deck's files and of every setting of `bin` that reaches LIGGGHTS: the name of the
// recordings' cache.
inline std::string deckKey(const LayeredBin& bin) {
  std::ostringstream text;
  for (const char* file : {"materials.in", "deposit.in", "drag.in", "plate.stl"}) {
    std::ifstream in(layeredBinDeck() / file, std::ios::binary);
    if (!in) throw std::runtime_error("cannot read " + (layeredBinDeck() / file).string());
    text << in.rdbuf() << '\n';
  }
  text << num(bin.width_m) << num(bin.length_m) << num(bin.fill_m) << num(bin.interface_m) << num(bin.start_z_m) << num(bin.stroke_m)
       << num(bin.velocity_m_s) << num(bin.insertion_velocity_m_s) << frictionVariables(bin);
  for (double d : bin.depths_mm) text << ' ' << num(d);
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : text.str()) h = (h ^ c) * 1099511628211ull;
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
  return hex;
}

}  // namespace detail

// The recordings of `bin` from the cache `cache_dir`/<deck key>: run (runLayeredBin in a working
// directory of this process) and copied there when any is missing, so that the tests of one build
// run the deck once per bin. A recording enters the cache CSV first, its sidecar last (each by a
// rename), so a cache entry with a sidecar is complete.
inline std::vector<std::filesystem::path> cachedLayeredBin(const LayeredBin& bin, const std::filesystem::path& cache_dir) {
  namespace fs = std::filesystem;
  const fs::path dir = cache_dir / ("liggghts-" + detail::deckKey(bin));
  std::vector<fs::path> cached;
  for (int seed = 1; seed <= bin.seeds; ++seed)
    for (double depth_mm : bin.depths_mm) cached.push_back(dir / ("seed" + std::to_string(seed) + "_" + detail::num(depth_mm) + "mm.csv"));
  bool complete = true;
  for (const auto& f : cached) complete = complete && fs::exists(fs::path(f).replace_extension(".json"));
  if (complete) return cached;
  const fs::path work = cache_dir / ("work-" + std::to_string(::getpid()));
  const auto made = runLayeredBin(bin, work);
  fs::create_directories(dir);
  for (const auto& f : made)
    for (const char* ext : {".csv", ".json"}) {
      const fs::path from = fs::path(f).replace_extension(ext), to = dir / from.filename();
      fs::copy_file(from, fs::path(to).concat(".part"), fs::copy_options::overwrite_existing);
      fs::rename(fs::path(to).concat(".part"), to);
    }
  fs::remove_all(work);
  return cached;
}

}  // namespace demfem::campaign::test

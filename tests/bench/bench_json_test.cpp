// The benchmarks as their users run them, on a small bin: one JSON document on standard output with
// --json -, holding figures consistent with their definitions (the rates are not checked: no timed
// tests).
#include "apps/process.hpp"

#include <catch2/catch.hpp>

#include <cstdlib>

using namespace demfem::testing;

namespace {

// studies/quick.json on a 140 x 80 mm bin (about 500 particles) with the 120 x 20 mm tool, a short stroke.
fs::path smallStudy(const fs::path& dir) {
  nlohmann::json study = shippedStudyJson("quick.json");
  useSmallBin(study);
  useSmallTool(study);
  useShortStroke(study, 20);
  return writeStudy(study, dir / "small.json");
}

}  // namespace

TEST_CASE("builtin_bench times the thread counts in turns over all their steps and --twin counts the work of both processes",
          "[bench]") {
  const fs::path dir = freshDir("bench_builtin_twin");
  constexpr int kSteps = 40;  // turns of 15, 15 and 10 steps
  const nlohmann::json doc = jsonStdout({BUILTIN_BENCH, "--study", smallStudy(dir).string(), "--soil-dir", (dir / "soil").string(),
                                         "--steps", std::to_string(kSteps), "--rounds", "2", "--threads", "1", "2", "--twin",
                                         "--slice-steps", "15", "--warmup-steps", "5", "--model", "hooke+history+cdt", "--json", "-"},
                                        dir / "builtin_bench");
  CHECK(doc.at("slice_steps") == 15);
  CHECK(doc.at("warmup_steps") == 5);
  std::vector<nlohmann::json> twins, alone_1;
  int in_turns = 0;
  for (const auto& c : doc.at("cases")) {
    if (c.at("twin_processes").get<bool>()) {
      twins.push_back(c);
      continue;
    }
    if (!c.at("competing_process").get<bool>() && c.at("threads") == 1) alone_1.push_back(c);
    // The warm-up and every turn ran, and the rate is all the steps of the count's turns over the
    // time of its turns alone.
    CHECK(c.at("simulated_time_s").get<double>() == Approx((5 + kSteps) * c.at("dt_s").get<double>()).epsilon(1e-9));
    const double rate = c.at("particles").get<double>() * kSteps / c.at("wall_s").get<double>();
    CHECK(c.at("particle_steps_per_s").get<double>() == Approx(rate).epsilon(1e-12));
    // The team's phases: none with 1 thread, at least two a step with 2, some of them perhaps
    // run by the caller alone.
    const long phases = c.at("team_phases").get<long>(), alone = c.at("team_phases_alone").get<long>();
    if (c.at("threads") == 1)
      CHECK(phases == 0);
    else
      CHECK(phases >= 2 * (5 + kSteps));
    CHECK(alone >= 0);
    CHECK(alone <= phases);
    ++in_turns;
  }
  CHECK(in_turns == 4);        // 1 and 2 threads, two rounds
  REQUIRE(twins.size() == 2);  // one per round
  REQUIRE(alone_1.size() == 2);
  for (std::size_t r = 0; r < twins.size(); ++r) {
    const auto& t = twins[r];
    CHECK(t.at("threads") == 1);
    CHECK(t.at("round") == r + 1);
    // Both processes' work over the time until both were done.
    const double both = 2.0 * t.at("particles").get<double>() * kSteps / t.at("wall_s").get<double>();
    CHECK(t.at("particle_steps_per_s").get<double>() == Approx(both).epsilon(1e-12));
    CHECK(t.at("cpu_s").get<double>() > 0);  // both processes' processor time
  }
  int twin_summaries = 0;
  for (const auto& s : doc.at("summary"))
    if (s.at("twin_processes").get<bool>()) {
      ++twin_summaries;
      // The ratio is against 1 thread alone in the same round.
      std::vector<double> ratios{twins[0].at("particle_steps_per_s").get<double>() / alone_1[0].at("particle_steps_per_s").get<double>(),
                                 twins[1].at("particle_steps_per_s").get<double>() / alone_1[1].at("particle_steps_per_s").get<double>()};
      CHECK(s.at("lowest_ratio_to_first_thread_count").get<double>() == Approx(std::min(ratios[0], ratios[1])).epsilon(1e-12));
    }
  CHECK(twin_summaries == 1);
}

TEST_CASE("demfem-bench-coupled splits a coupled run into DEM, FEM step, protocol, outputs and its opening and closing",
          "[bench]") {
  const fs::path dir = freshDir("bench_coupled_split");
  ::setenv("DEMFEM_SOIL_DIR", (dir / "soil").c_str(), 1);  // inherited by the benchmark
  constexpr int kSteps = 30;
  const nlohmann::json doc = jsonStdout({COUPLED_BENCH, "--study", smallStudy(dir).string(), "--steps", std::to_string(kSteps),
                                         "--rounds", "1", "--integrations", "modal", "--placements", "in-process", "remote",
                                         "--json", "-"},
                                        dir / "bench_coupled");
  const auto& runs = doc.at("runs");
  REQUIRE(runs.size() == 2);
  for (const auto& r : runs) {
    INFO(r.dump());
    CHECK(r.at("steps") == kSteps);
    CHECK(r.at("dem_per_step_ms").get<double>() > 0);
    CHECK(r.at("fem_step_per_step_ms").get<double>() > 0);
    CHECK(r.at("open_close_s").get<double>() >= 0);
    const double fem_share = r.at("fem_and_protocol_wall_percent").get<double>();
    CHECK(fem_share > 0);
    CHECK(fem_share < 100);
    CHECK(r.at("process_cpu_per_wall").get<double>() > 0);
  }
  CHECK(runs[0].at("dem") == "in-process");
  CHECK(runs[0].at("protocol_per_step_ms").get<double>() == 0);  // nothing between the client and an in-process DEM
  CHECK(runs[1].at("dem") == "remote");
  CHECK(runs[1].at("outputs_inline_per_step_ms").get<double>() == 0);  // remote, the outputs run during the interval
}

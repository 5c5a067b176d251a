// The progress reporter every long phase uses: what it prints, where, and how often.
#include "demfem/cli/progress.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <iostream>
#include <sstream>
#include <thread>

using demfem::cli::Progress;
using namespace std::chrono_literals;

TEST_CASE("the time left is the elapsed time scaled by the fraction still to do", "[apps]") {
  CHECK(Progress::secondsLeft(0.25, 10.0) == Approx(30.0));
  CHECK(Progress::secondsLeft(1.0, 10.0) == 0.0);
  CHECK(Progress::secondsLeft(0.0, 10.0) < 0.0);  // unknown before anything is done
  CHECK(Progress::formatDuration(12.4) == "12 s");
  CHECK(Progress::formatDuration(185) == "3 min 05 s");
  CHECK(Progress::formatDuration(3720) == "1 h 02 min");
}

TEST_CASE("progress lines name the phase, the percentage and the time left, at most once per interval", "[apps]") {
  std::ostringstream out;
  Progress p("keypoint reduction", true, out, false, 50ms, 0ms);
  std::this_thread::sleep_for(60ms);
  p.update(0.5, "block 3 of 6");
  p.update(0.6);  // within the interval: not printed
  const std::string first = out.str();
  CHECK_THAT(first, Catch::StartsWith("keypoint reduction: 50 % (block 3 of 6) ETA "));
  CHECK(std::count(first.begin(), first.end(), '\n') == 1);
  std::this_thread::sleep_for(60ms);
  p.update(0.75);
  p.update(1.0);  // the end is finish()'s line
  p.finish("738 keypoints");
  const std::string all = out.str();
  CHECK(std::count(all.begin(), all.end(), '\n') == 3);
  CHECK_THAT(all, Catch::Contains("\nkeypoint reduction: 75 % ETA "));
  CHECK_THAT(all, Catch::Contains("\nkeypoint reduction: done in "));
  CHECK_THAT(all, Catch::EndsWith(" s (738 keypoints)\n"));
}

TEST_CASE("a time left the caller knows is printed as given, and as unknown when negative", "[apps]") {
  // A resumed campaign is 90 % done at its start: the elapsed time scaled by the fraction would
  // say seconds where the caller's rate of this call's work says hours.
  std::ostringstream out;
  Progress p("convergence", true, out, false, 0ms, 0ms);
  p.update(0.9, 7200.0, "3 runs to make");
  p.update(0.9, -1.0, "3 runs to make");
  CHECK(out.str() == "convergence: 90 % (3 runs to make) ETA 2 h 00 min\nconvergence: 90 % (3 runs to make) ETA unknown\n");
}

TEST_CASE("a disabled or quick phase prints nothing", "[apps]") {
  std::ostringstream out;
  Progress quiet("deposition", false, out, false, 0ms, 0ms);
  quiet.update(0.5);
  quiet.finish();
  Progress quick("modal", true, out, false, 0ms, 10s);
  quick.update(0.5);
  quick.finish();
  CHECK(out.str().empty());
}

TEST_CASE("deposition progress names the study whose soil it deposits and prints its stage lines as they come", "[apps]") {
  std::ostringstream err;
  std::streambuf* const saved = std::cerr.rdbuf(err.rdbuf());
  const auto report = demfem::cli::depositionProgress(true);
  report("pmma_coupled_18", 0.2, "stage 1: kinetic energy 3e-3 J");
  report("pmma_coupled_18", 0.4, "");
  const auto quiet = demfem::cli::depositionProgress(false);
  quiet("s235_dem_42", 0.5, "stage 1: kinetic energy 2e-3 J");
  std::cerr.rdbuf(saved);
  CHECK(err.str() == "deposition of the soil of pmma_coupled_18: stage 1: kinetic energy 3e-3 J\n");
}

// CPR statistics against hand-computed values, and the measured-profile reader.
#include "demfem/analysis/cone_penetration.hpp"
#include "demfem/analysis/recording.hpp"
#include "support/temp_dir.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>

using namespace demfem::analysis;

namespace {

CprProfile linear(const std::string& label, double slope_Pa_per_m, double step_m, int samples) {
  CprProfile p{label, {}, {}};
  for (int k = 1; k <= samples; ++k) {
    p.depth_m.push_back(k * step_m);
    p.cpr_Pa.push_back(slope_Pa_per_m * k * step_m);
  }
  return p;
}

void write(const std::filesystem::path& file, const std::string& text) {
  std::ofstream out(file);
  out << text;
  REQUIRE(out.good());
}

}  // namespace

TEST_CASE("CPR is the vertical force over the projected area", "[analysis]") {
  CHECK(coneResistance_Pa(50.0, 5e-4) == Approx(1e5).epsilon(1e-15));
}

TEST_CASE("CPR mean, standard deviation and mean deviation of three cones", "[analysis]") {
  // Profiles proportional to depth with slopes 1, 2, 3 MPa/m: mean 2 MPa/m x d, sample std 1 MPa/m x d,
  // so std/mean = 0.5 at every depth.
  const std::vector<CprProfile> cones{linear("a", 1e6, 1e-4, 600), linear("b", 2e6, 1e-4, 555), linear("c", 3e6, 1e-4, 580)};
  const auto s = summarize("layered", cones, 1e-3);
  REQUIRE(s.depth_m.size() == 55);  // 1 ... 55 mm: the shallowest profile ends at 55.5 mm
  CHECK(s.depth_m.front() == Approx(1e-3));
  for (std::size_t k = 0; k < s.depth_m.size(); ++k) {
    // The samples within +-0.5 mm of depth d average to d (symmetric bin of 10 samples, 0.1 mm apart).
    const double d = s.depth_m[k];
    CHECK(s.mean_Pa[k] == Approx(2e6 * d).epsilon(0.06));
    CHECK(s.std_Pa[k] / s.mean_Pa[k] == Approx(0.5).epsilon(1e-9));
  }
  CHECK(s.mean_deviation == Approx(0.5).epsilon(1e-9));
  CHECK_THROWS_WITH(summarize("one", {cones[0]}, 1e-3), Catch::Contains("at least two profiles"));
}

TEST_CASE("sparse measured profiles are interpolated onto the grid", "[analysis]") {
  const CprProfile a{"repeat 1", {0.0, 0.01, 0.02}, {0.0, 1e5, 2e5}}, b{"repeat 2", {0.0, 0.01, 0.02}, {0.0, 3e5, 6e5}};
  const auto s = summarize("measured", {a, b}, 5e-3);
  REQUIRE(s.depth_m.size() == 4);  // 5, 10, 15, 20 mm
  CHECK(s.mean_Pa[0] == Approx(1e5));       // (0.5e5 + 1.5e5) / 2 at 5 mm, interpolated
  CHECK(s.mean_Pa[3] == Approx(4e5));
  CHECK(s.std_Pa[1] == Approx(std::sqrt(2.0) * 1e5));
  // Simulated mean 2e5 x d/10mm against measured 2e5 x d/10mm +- 1.41e5 x d/10mm: always within.
  const CprProfile c{"cone1", {0.0, 0.02}, {0.0, 3e5}}, e{"cone2", {0.0, 0.02}, {0.0, 5e5}};
  const auto sim = summarize("sim", {c, e}, 5e-3);
  const auto cmp = compare(sim, s);
  CHECK(cmp.depths == 4);
  CHECK(cmp.within_measured_band == 1.0);
  CHECK(cmp.mean_relative_difference == Approx(0.0).margin(1e-12));
}

TEST_CASE("a measured CPR profile is read with its sidecar, and bad ones are refused by file and line", "[analysis]") {
  demfem::support::TempDir dir("cpr");
  write(dir / "cpr_1.csv", "# penetrologger\ndepth_mm,CPR_kPa\n0,0\n10,250\n20,410\n");
  write(dir / "cpr_1.json", R"({"kind": "cone-penetration", "soil": "sandy", "repeat": 1, "area_mm2": 500})");
  const auto m = readMeasuredProfile(dir / "cpr_1.csv");
  CHECK(m.soil == "sandy");
  CHECK(m.area_m2 == Approx(5e-4));
  CHECK(m.profile.depth_m == std::vector<double>{0.0, 0.01, 0.02});
  CHECK(m.profile.cpr_Pa[2] == Approx(4.1e5));
  write(dir / "cpr_2.csv", "depth_mm,CPR_kPa\n0,0\n10,250\n5,410\n");
  write(dir / "cpr_2.json", R"({"kind": "cone-penetration", "soil": "sandy", "repeat": 2, "area_mm2": 500})");
  CHECK_THROWS_WITH(readMeasuredProfile(dir / "cpr_2.csv"), Catch::Contains("cpr_2.csv:4:1: column 'depth_mm'"));
  write(dir / "cpr_3.csv", "depth_mm,CPR_kPa\n0,0\n10,250\n");
  write(dir / "cpr_3.json", R"({"kind": "soil-bin", "soil": "sandy", "repeat": 3, "area_mm2": 500})");
  CHECK_THROWS_WITH(readMeasuredProfile(dir / "cpr_3.csv"), Catch::Contains("cpr_3.json: /kind:"));
}

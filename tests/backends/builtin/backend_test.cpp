// The builtin backend through the coupling API on a small deposited bin with a plate tool.
#include "demfem/adapter/checkpoint_file.hpp"
#include "demfem/adapter/plate_surface.hpp"
#include "demfem/adapter/settled_soil.hpp"
#include "demfem/adapter/tool_drive.hpp"
#include "demfem/backends/builtin/backend.hpp"
#include "demfem/backends/builtin/soil_bin.hpp"
#include "support/study_in_code.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <random>
#include <numbers>
#include <vector>

using namespace demfem;

namespace {

// A 120 x 120 mm bin with 40 mm of soil (two layers), a 40 x 100 x 4 mm plate at 10 mm depth.
study::Study smallStudy() {
  study::Study s = support::twoLayerTestBin("builtin-small", study::StudyKind::Coupled);
  study::Tool tool;
  tool.dem_material = "steel";
  support::usePlate(tool, 0.1, 0.04, 0.004);
  tool.motion.depth_m = 0.01;
  tool.motion.velocity_m_s = 0.036;
  tool.motion.start_z_m = 0.03;
  tool.motion.center_x_m = 0.06;  // the bin's centre line
  tool.motion.insertion_velocity_m_s = 0.05;
  tool.motion.stroke_m = 0.08;  // the path stays in the 120 mm bin (the tests drive the tool themselves)
  tool.fem = {true, 4.06e9, 0.38, 1220, 0.00055, 0, study::ElementOrder::Quadratic};  // quick.json's PMMA (the DEM ignores it)
  s.tools = {tool};
  support::useBuiltinStep(s, 0.001);
  study::validate(s);  // the loader's gate, also for a study built in code
  return s;
}

struct SoilDirectory {
  std::filesystem::path dir = std::filesystem::temp_directory_path() / "demfem-builtin-backend-test";
  SoilDirectory() {
    std::filesystem::create_directories(dir);
    ::setenv("DEMFEM_SOIL_DIR", dir.c_str(), 1);
  }
};

}  // namespace

TEST_CASE("builtin backend deposits a layered soil once and serves the coupling calls", "[builtin]") {
  const SoilDirectory soil_dir;
  const study::Study st = smallStudy();
  auto api = builtin::makeBackend(st);
  const auto soil_file = adapter::settledSoilFile(st, soil_dir.dir);
  REQUIRE(std::filesystem::exists(soil_file));

  SECTION("settled soil: layers by depth, surface at the fill height, its figures recorded") {
    const auto soil = adapter::readSettledSoil(soil_file, st);
    CHECK(soil.particles.size() > 300);
    for (const auto& p : soil.particles) {
      CHECK(p.x_m[1] <= st.soil.fill_height_m);
      // Tagged by the depth of its centre before the final settling; the final settling and the
      // reload phase (particles keep their layer) move a centre across the 10 mm boundary by well
      // under 1 mm (measured 0.37 mm, 2026-12-08).
      const double depth = st.soil.fill_height_m - p.x_m[1];
      INFO("depth " << depth);
      if (std::fabs(depth - 0.01) > 1e-3) CHECK(p.layer == (depth < 0.01 ? 0 : 1));
    }
    CHECK(soil.backend == "builtin");
    CHECK(soil.seed == st.soil.deposition_seed);
    CHECK(soil.settling.stages == 3);  // the pour, the final settling and the reload phase
    CHECK(soil.settling.bulk_density_kg_m3 == adapter::bulkDensity(soil.particles, st.soil));
    CHECK(soil.settling.coordination_number == adapter::meanCoordinationNumber(soil.particles));
    CHECK(soil.settling.threshold_J == st.soil.settle_kinetic_energy_J);
    CHECK(soil.settling.surface_height_m == adapter::soilSurfaceHeight(soil.particles, st.soil.diameter_max_m));
    CHECK(soil.settling.surface_height_m > st.soil.fill_height_m - st.soil.diameter_max_m);
    CHECK(soil.settling.surface_height_m < st.soil.fill_height_m + st.soil.diameter_max_m / 2);
    // The run records the soil it started from.
    const auto record = nlohmann::json::parse(api->info().soil_json);
    CHECK(record.at("particles") == soil.particles.size());
    CHECK(record.at("file") == soil_file.string());
    CHECK(record.at("file_checksum") == adapter::settledSoilChecksum(soil_file));
    CHECK(record.at("settled") == adapter::unsettledReason(soil.settling).empty());
  }

  SECTION("another core count runs on the same soil file") {
    study::Study two = st;
    two.dem.threads = 2;
    const auto before = std::filesystem::last_write_time(soil_file);
    auto again = builtin::makeBackend(two);
    CHECK(adapter::settledSoilFile(two, soil_dir.dir) == soil_file);
    CHECK(std::filesystem::last_write_time(soil_file) == before);  // read, not deposited again
    CHECK(nlohmann::json::parse(again->info().soil_json).at("file_checksum") == adapter::settledSoilChecksum(soil_file));
  }

  SECTION("geometry and node positions are the plate's keypoints") {
    const auto plate = adapter::makePlateSurface(0.1, 0.04, 0.004, 0.005);
    const auto geos = api->geometries();
    REQUIRE(geos.size() == 1);
    CHECK(geos[0].name == "tool");
    CHECK(geos[0].node_count == static_cast<std::int32_t>(plate.nodes.size()));
    CHECK(geos[0].triangles == plate.triangles);
    const auto xyz = api->nodePositions("tool");
    for (std::size_t k = 0; k < plate.nodes.size(); ++k)
      for (int c = 0; c < 3; ++c) CHECK(xyz[3 * k + c] == plate.nodes[k][c]);
    // At rest at the plan's start (coupling_api.hpp): tip one largest diameter above the fill
    // surface, centred across the bin, front face (z = +T/2) at start_z; clock at 0.
    const auto motion = api->rigidMotion("tool");
    CHECK(motion.origin_m[0] == 0.06);
    CHECK(motion.origin_m[1] == Approx(st.soil.fill_height_m + st.soil.diameter_max_m).margin(1e-15));
    CHECK(motion.origin_m[2] == Approx(0.03 - 0.002).margin(1e-15));
    CHECK(motion.velocity_m_s == std::array<double, 3>{0, 0, 0});
    CHECK(api->time() == 0);
  }

  SECTION("interval mean is the impulse over the interval; the DEM step divides the FEM step") {
    // Right after the insertion the tool touches the soil (a few hundred grains: later in the drag,
    // contacts come and go).
    adapter::insertAndStartDrag(*api, st, st.tools[0]);
    // Interval mean = average of the instantaneous forces of its DEM steps (same state, restored).
    const double dt = api->info().dem_time_step_s;
    const auto file = std::filesystem::temp_directory_path() / "demfem-builtin-backend-test" / "mean.bin";
    api->checkpoint(file);
    api->simulate(10 * dt);
    const auto mean = api->nodeForces("tool");
    api->restore(file);
    std::vector<double> sum(mean.size(), 0.0);
    for (int k = 0; k < 10; ++k) {
      api->simulate(dt);
      const auto now = api->nodeForces("tool", adapter::ForceMode::Instantaneous);
      for (std::size_t q = 0; q < sum.size(); ++q) sum[q] += now[q] / 10;
    }
    double scale = 0;
    for (double f : sum) scale = std::max(scale, std::fabs(f));
    REQUIRE(scale > 0);
    for (std::size_t q = 0; q < sum.size(); ++q) CHECK(mean[q] == Approx(sum[q]).margin(1e-12 * scale));
    const double t0 = api->time();
    for (int k = 0; k < 20; ++k) api->simulate(0.001);
    CHECK(api->time() - t0 == Approx(0.02).epsilon(1e-9));  // the DEM step divides the FEM step
  }

  SECTION("deformation keeps the run going; checkpoint and restore continue bit-identically") {
    adapter::insertAndStartDrag(*api, st, st.tools[0]);
    auto xyz = api->nodePositions("tool");
    for (std::size_t k = 0; k < xyz.size() / 3; ++k) xyz[3 * k + 2] += 1e-4 * (0.1 - xyz[3 * k + 1]) / 0.1;  // tip bent back
    api->setNodePositions("tool", xyz);
    api->simulate(0.002);
    const auto file = soil_dir.dir / "checkpoint.bin";
    api->checkpoint(file);
    api->simulate(0.003);
    const auto a = api->nodeForces("tool", adapter::ForceMode::Instantaneous);
    const double ta = api->time();
    api->restore(file);
    api->simulate(0.003);
    const auto b = api->nodeForces("tool", adapter::ForceMode::Instantaneous);
    CHECK(api->time() == ta);
    REQUIRE(a.size() == b.size());
    CHECK(std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
  }

  SECTION("a checkpoint with flipped bytes, cut short or inconsistent is refused; the state stays as it was") {
    api->simulate(0.002);
    const auto file = soil_dir.dir / "corrupt.ckpt";
    api->checkpoint(file);
    api->simulate(0.002);
    const double time = api->time();
    const auto forces = api->nodeForces("tool", adapter::ForceMode::Instantaneous);
    std::string image;
    {
      std::ifstream in(file, std::ios::binary);
      image.assign(std::istreambuf_iterator<char>(in), {});
    }
    const auto write = [&](const std::string& bytes) { std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes; };
    const auto refusedAndUnchanged = [&](const std::string& bytes) {
      write(bytes);
      CHECK_THROWS_AS(api->restore(file), adapter::CouplingError);
      CHECK(api->time() == time);
      CHECK(api->nodeForces("tool", adapter::ForceMode::Instantaneous) == forces);
    };
    std::mt19937 rng(11);
    std::string flipped = image;
    for (int k = 0; k < 200; ++k) flipped[rng() % flipped.size()] ^= static_cast<char>(1 + rng() % 255);
    refusedAndUnchanged(flipped);
    refusedAndUnchanged(image.substr(0, image.size() / 2));
    refusedAndUnchanged(image.substr(0, image.size() - 1));
    // Checksummed but inconsistent: a particle's material index out of range, an array cut short.
    std::string payload = adapter::checkpointPayload(image, "builtin", "image");
    refusedAndUnchanged(adapter::checkpointImage("builtin", payload.substr(0, payload.size() - 8)));
    for (std::size_t at : {payload.size() / 3, payload.size() / 2}) {
      std::string bad = payload;
      std::memset(bad.data() + at, 0xff, 64);
      write(adapter::checkpointImage("builtin", bad));
      try {  // refused, or (if the bytes hit plain values) accepted; never a crash when it runs on
        api->restore(file);
        api->simulate(0.001);
      } catch (const adapter::CouplingError&) {
      }
      write(image);
      api->restore(file);
    }
    // The intact file still restores, and the run continues from it.
    write(image);
    api->restore(file);
    api->simulate(0.002);
    CHECK(api->time() == Approx(time).epsilon(1e-12));
    CHECK(api->nodeForces("tool", adapter::ForceMode::Instantaneous) == forces);
  }

  SECTION("errors carry codes") {
    try {
      api->nodeForces("plough");
      FAIL("no error for an unknown geometry");
    } catch (const adapter::CouplingError& e) {
      CHECK(e.code() == adapter::ErrorCode::UnknownGeometry);
    }
    try {
      api->setNodePositions("tool", adapter::NodeArray(5, 0.0));
      FAIL("no error for a wrong size");
    } catch (const adapter::CouplingError& e) {
      CHECK(e.code() == adapter::ErrorCode::SizeMismatch);
    }
    api->shutdown();
    CHECK_THROWS_AS(api->simulate(0.001), adapter::CouplingError);
  }
}

namespace {

// Mean z force of the particles on the tool (sum over its nodes, N) over the second half of a
// `drag_m` drag, and its standard error from 10 ms block means.
struct Draught {
  double mean_N = 0, standard_error_N = 0;
};

Draught dragTool(const study::Study& st, double drag_m) {
  auto api = builtin::makeBackend(st);
  adapter::insertAndStartDrag(*api, st, st.tools[0]);
  const double interval = 0.01;
  const int intervals = static_cast<int>(std::lround(drag_m / st.tools[0].motion.velocity_m_s / interval));
  std::vector<double> fz;
  for (int k = 0; k < intervals; ++k) {
    api->simulate(interval);
    if (k < intervals / 2) continue;
    const auto f = api->nodeForces("tool");
    double sum = 0;
    for (std::size_t q = 2; q < f.size(); q += 3) sum += f[q];
    fz.push_back(sum);
  }
  Draught d;
  for (double v : fz) d.mean_N += v / static_cast<double>(fz.size());
  double var = 0;
  for (double v : fz) var += (v - d.mean_N) * (v - d.mean_N) / static_cast<double>(fz.size() - 1);
  d.standard_error_N = std::sqrt(var / static_cast<double>(fz.size()));
  return d;
}

}  // namespace

TEST_CASE("dragging the tool through the soil loads it against the travel, more the deeper it cuts", "[builtin]") {
  const SoilDirectory soil_dir;
  study::Study shallow = smallStudy();  // 10 mm deep, front face at z = 30 mm, dragged along +z
  study::Study deep = shallow;
  deep.tools[0].motion.depth_m = 0.02;  // 20 mm above the floor: two grains, no jamming under the tip
  // 40 mm of travel (the bin is 120 mm long); the mean is taken over the last 20 mm, and over three
  // deposition seeds: one realisation of a bin of a few hundred grains scatters by tens of percent
  // (docs/builtin-dem.md: compare seeds), and the ratio of two of them more.
  constexpr int kSeeds = 3;
  Draught d10, d20;
  for (int seed = 1; seed <= kSeeds; ++seed) {
    shallow.soil.deposition_seed = deep.soil.deposition_seed = static_cast<std::uint64_t>(seed);
    const Draught a = dragTool(shallow, 0.04), b = dragTool(deep, 0.04);
    UNSCOPED_INFO("seed " << seed << ": draught at 10 mm " << a.mean_N << " +- " << a.standard_error_N << " N, at 20 mm "
                          << b.mean_N << " +- " << b.standard_error_N << " N");
    d10.mean_N += a.mean_N / kSeeds, d20.mean_N += b.mean_N / kSeeds;
    d10.standard_error_N += a.standard_error_N * a.standard_error_N / (kSeeds * kSeeds);
    d20.standard_error_N += b.standard_error_N * b.standard_error_N / (kSeeds * kSeeds);
  }
  d10.standard_error_N = std::sqrt(d10.standard_error_N), d20.standard_error_N = std::sqrt(d20.standard_error_N);
  INFO("draught at 10 mm: " << d10.mean_N << " +- " << d10.standard_error_N << " N; at 20 mm: " << d20.mean_N << " +- "
                            << d20.standard_error_N << " N (means over " << kSeeds << " seeds)");
  // The soil pushes the tool back (-z), well beyond the scatter of the mean.
  CHECK(d10.mean_N < -3 * d10.standard_error_N);
  CHECK(d20.mean_N < -3 * d20.standard_error_N);
  // Passive earth pressure grows with the square of the depth (Rankine: F = gamma d^2 Kp w / 2, a
  // factor (20/10)^2 = 4 here). The tip engages grains centred up to a radius R below it, so the
  // depth that counts is d + R, and friction on the plate's faces adds a part linear in it: the
  // draught grows at least as fast as d + R, a factor (20 + R) / (10 + R) = 1.66 for R = 5.25 mm
  // (measured on two machines on the old lattice deposition, one seed, whose libm rounds differently
  // and so give two realisations of this chaotic pack: 1.89 and above 2; on the gravity pour of
  // 2026-12-07 seed 1 alone gives 1.20 (1.50 and 1.79 N), the mean of seeds 1-3 1.70 (1.12 and 1.91 N).
  const double grain_radius_m = shallow.soil.diameter_max_m / 2;
  CHECK(d20.mean_N < (0.02 + grain_radius_m) / (0.01 + grain_radius_m) * d10.mean_N);

  // Magnitude at 20 mm against Rankine's passive pressure on the 40 mm wide plate, with the unit
  // weight of the settled soil and the assembly's friction angle bracketed by 20-55 degrees
  // (Kp = (1 + sin phi) / (1 - sin phi); inter-particle friction 0.6 with rolling friction 0.1
  // gives assemblies whose angle of repose passes 50 degrees). The upper end allows for what a 2D
  // continuum misses: the tip engages grains centred up to a radius below it (depth d + R), and a
  // plate only twice as wide as deep fails the soil beside it too: McKyes and Ali's side crescents
  // multiply the weight term by 1 + (2/3) r / w, r = d cot(45 - phi/2) the rupture distance,
  // 1.8 here at 45 degrees. The bracket is wide because the mean of one chaotic realisation in a
  // bin of a few hundred grains scatters by tens of percent.
  const auto settled = adapter::readSettledSoil(adapter::settledSoilFile(deep, soil_dir.dir));
  double solid_volume = 0;
  for (const auto& p : settled.particles) solid_volume += 4.0 / 3.0 * std::numbers::pi * std::pow(p.radius_m, 3);
  const auto& soil = deep.soil;
  const double gamma = 2600 * 9.81 * solid_volume / (soil.bin_length_m * soil.bin_width_m * soil.fill_height_m);
  const auto kp = [](double phi_deg) {
    const double s = std::sin(phi_deg * std::numbers::pi / 180);
    return (1 + s) / (1 - s);
  };
  const double width = deep.tools[0].geometry.width_m, depth = 0.02, grain = soil.diameter_max_m / 2;
  const double rankine = 0.5 * gamma * depth * depth * width;
  const double rankine_tip = 0.5 * gamma * (depth + grain) * (depth + grain) * width;
  CHECK(-d20.mean_N > rankine * kp(20));
  CHECK(-d20.mean_N < 1.8 * rankine_tip * kp(55));
}

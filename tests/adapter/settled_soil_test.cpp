// The backend-neutral settled-soil file (adapter/settled_soil.hpp): exact round trip, refusal of
// damaged, truncated and foreign files with the file named, the settledness rule, the figures.
#include "demfem/adapter/settled_soil.hpp"

#include "support/grain_soil.hpp"

#include <catch2/catch.hpp>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <numbers>
#include <thread>
#include <unistd.h>

namespace {

using namespace demfem;
namespace fs = std::filesystem;

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("demfem-settled-soil-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  return dir / name;
}

adapter::SettledSoil sample() {
  adapter::SettledSoil soil;
  soil.soil_hash = "0123456789abcdef";
  soil.backend = "liggghts";
  soil.seed = 7;
  soil.cores = 2;
  soil.settling = {3.5e-7, 1e-6, 5, 0, false, 2.25, 0.0498, 0.55, 1430.5, 4.52, 1450.0, 0.375};
  // Values whose every bit matters: no decimal text would keep them.
  soil.particles = {{{0.1 / 3, std::nextafter(0.02, 1.0), 0.3}, 0.00475 + 1e-17, 0},
                    {{std::numbers::pi / 100, 0.011, 1e-300}, 0.005, 2},
                    {{0.25, 0.0, 0.65}, 0.0052500000000000003, 1}};
  return soil;
}

std::string bytesOf(const fs::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void writeBytes(const fs::path& file, const std::string& bytes) {
  std::ofstream(file, std::ios::binary).write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

// The message names the file and contains `what`.
void requireRefused(const fs::path& file, const std::string& what) {
  try {
    adapter::readSettledSoil(file);
    FAIL("read " << file << " without complaint");
  } catch (const std::runtime_error& e) {
    const std::string message = e.what();
    INFO(message);
    CHECK(message.find(file.string()) != std::string::npos);
    CHECK(message.find(what) != std::string::npos);
  }
}

}  // namespace

TEST_CASE("a settled soil reads back bit for bit with its header", "[adapter][soil]") {
  const auto file = scratch("roundtrip.bin");
  const auto soil = sample();
  adapter::writeSettledSoil(file, soil);
  const auto back = adapter::readSettledSoil(file);
  CHECK(back == soil);  // every double compared exactly
  CHECK(back.particles[0].x_m[1] == std::nextafter(0.02, 1.0));
  // Layout: 8 magic + 4 version + 4 header length + header + 36 per particle + 8 checksum.
  const std::string bytes = bytesOf(file);
  std::uint32_t header_length = 0;
  std::memcpy(&header_length, bytes.data() + 12, 4);
  CHECK(bytes.size() == 16 + header_length + 36 * soil.particles.size() + 8);
  CHECK(bytes.substr(0, 8) == "DFSOILNT");
  CHECK(adapter::settledSoilChecksum(file).size() == 16);
}

TEST_CASE("a damaged, truncated or foreign settled-soil file is refused with its name", "[adapter][soil]") {
  const auto good = scratch("good.bin");
  adapter::writeSettledSoil(good, sample());
  const std::string bytes = bytesOf(good);

  const auto flipped = scratch("flipped.bin");
  std::string f = bytes;
  f[f.size() - 20] ^= 0x01;  // one bit of the last particle's radius
  writeBytes(flipped, f);
  requireRefused(flipped, "checksum");

  const auto truncated = scratch("truncated.bin");
  writeBytes(truncated, bytes.substr(0, bytes.size() - 36));
  requireRefused(truncated, "checksum");

  const auto stub = scratch("stub.bin");
  writeBytes(stub, bytes.substr(0, 20));
  requireRefused(stub, "truncated");

  const auto foreign = scratch("foreign.bin");
  writeBytes(foreign, "DFSOIL01 an older built-in soil file");
  requireRefused(foreign, "not a settled-soil file");

  const auto newer = scratch("newer.bin");
  std::string v = bytes;
  v[8] = 9;  // format version 9
  writeBytes(newer, v);
  requireRefused(newer, "format version 9");

  requireRefused(scratch("missing.bin"), "cannot be opened");
}

TEST_CASE("a soil of another study or with a layer the study lacks is refused", "[adapter][soil]") {
  study::Study s;
  s.soil = support::makeSoil({});
  auto soil = sample();
  const auto file = scratch("other.bin");
  adapter::writeSettledSoil(file, soil);
  CHECK_THROWS_WITH(adapter::readSettledSoil(file, s), Catch::Contains(file.string()) && Catch::Contains("soil hash"));
  soil.soil_hash = study::soilHash(s);
  adapter::writeSettledSoil(file, soil);
  CHECK_THROWS_WITH(adapter::readSettledSoil(file, s), Catch::Contains("layer 2"));  // one layer only
  soil.particles.pop_back();
  soil.particles.pop_back();
  adapter::writeSettledSoil(file, soil);
  CHECK(adapter::readSettledSoil(file, s).particles.size() == 1);
  CHECK(adapter::settledSoilFile(s, "dir") == fs::path("dir") / ("soil-" + study::soilHash(s) + ".bin"));
}

TEST_CASE("two depositions of one soil at once deposit it once; the second waits and reuses the file", "[adapter][soil]") {
  const auto file = scratch("once.bin");
  std::atomic<int> depositions{0};
  const auto deposit = [&] {
    ++depositions;
    std::this_thread::sleep_for(std::chrono::milliseconds(200));  // the second caller arrives meanwhile
    return sample();
  };
  bool first = false, second = false;
  std::thread a([&] { first = adapter::depositOnce(file, deposit); });
  std::thread b([&] { second = adapter::depositOnce(file, deposit); });
  a.join();
  b.join();
  CHECK(depositions == 1);
  CHECK(first != second);
  CHECK(adapter::readSettledSoil(file) == sample());
  CHECK_FALSE(adapter::depositOnce(file, deposit));  // kept
  CHECK(adapter::depositOnce(file, deposit, true));   // --force
  CHECK(depositions == 2);
}

TEST_CASE("a soil is settled only if its final phase met the threshold within its cap", "[adapter][soil]") {
  adapter::SettlingFigures s{3.5e-7, 1e-6, 5, 0, false, 2.0, 0.05, 0.55};
  CHECK(adapter::unsettledReason(s).empty());
  s.stages_capped = 3;  // earlier layer phases capped: the kept soil is still at rest
  CHECK(adapter::unsettledReason(s).empty());
  s.final_phase_capped = true;
  CHECK_THAT(adapter::unsettledReason(s), Catch::Contains("final settling phase hit its time cap"));
  s.final_phase_capped = false;
  s.kinetic_energy_J = 1e-6;  // not below
  CHECK_THAT(adapter::unsettledReason(s), Catch::Contains("not below"));
}

TEST_CASE("the refusal of an unsettled soil names the file, the reason, the fix and the override", "[adapter][soil]") {
  adapter::SettlingFigures s{3.5e-7, 1e-6, 5, 0, false, 2.0, 0.05, 0.55};
  CHECK(adapter::unsettledSoilMessage("soils/soil-x.bin", s).empty());
  s.kinetic_energy_J = 2e-6;
  CHECK_THAT(adapter::unsettledSoilMessage("soils/soil-x.bin", s),
             Catch::Contains("soils/soil-x.bin") && Catch::Contains("2e-06 J is not below") &&
                 Catch::Contains("settle_kinetic_energy_J and deposit it again") && Catch::Contains("--allow-unsettled-soil"));
}

TEST_CASE("surface height and packing fraction follow their definitions", "[adapter][soil]") {
  // Two particles at the top within one diameter of each other, one deep: mean of the two tops.
  const std::vector<adapter::SoilParticle> p{{{0, 0.045, 0}, 0.005, 0}, {{0, 0.040, 0}, 0.005, 0}, {{0, 0.01, 0}, 0.005, 0}};
  CHECK(adapter::soilSurfaceHeight(p, 0.0105) == Approx((0.050 + 0.045) / 2).epsilon(1e-15));
  study::Soil soil;
  soil.bin_width_m = 0.1, soil.bin_length_m = 0.2, soil.fill_height_m = 0.05;
  const double sphere = 4.0 / 3.0 * std::numbers::pi * 0.005 * 0.005 * 0.005;
  CHECK(adapter::packingFraction(p, soil) == Approx(3 * sphere / (0.1 * 0.2 * 0.05)).epsilon(1e-15));
}

TEST_CASE("bulk density weighs each particle with its layer's material density", "[adapter][soil]") {
  study::Soil soil;
  soil.bin_width_m = 0.1, soil.bin_length_m = 0.2, soil.fill_height_m = 0.05;
  soil.materials = {{"light", 1000, 1e7, 0.3, 0}, {"heavy", 2600, 1e7, 0.3, 0}};
  soil.layers = {{"light", 0, 0.01}, {"heavy", 0.01, 0.05}};
  const std::vector<adapter::SoilParticle> p{{{0.05, 0.045, 0.1}, 0.005, 0}, {{0.05, 0.02, 0.1}, 0.004, 1}};
  const double pi = std::numbers::pi;
  const double mass = 1000 * 4.0 / 3.0 * pi * 0.005 * 0.005 * 0.005 + 2600 * 4.0 / 3.0 * pi * 0.004 * 0.004 * 0.004;
  CHECK(adapter::bulkDensity(p, soil) == Approx(mass / (0.1 * 0.2 * 0.05)).epsilon(1e-14));
  const std::vector<adapter::SoilParticle> foreign{{{0.05, 0.045, 0.1}, 0.005, 2}};
  CHECK_THROWS_AS(adapter::bulkDensity(foreign, soil), std::invalid_argument);
}

TEST_CASE("the coordination number counts touching particle pairs twice over the particles", "[adapter][soil]") {
  // A 3 x 3 x 3 simple cubic lattice, neighbours overlapping by 0.1 mm, diagonals apart: 54 pairs.
  std::vector<adapter::SoilParticle> lattice;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) lattice.push_back({{0.0099 * i, 0.0099 * j, 0.0099 * k}, 0.005, 0});
  CHECK(adapter::meanCoordinationNumber(lattice) == Approx(2.0 * 54 / 27).epsilon(1e-15));
  // Spaced 0.1 mm apart: no contact.
  for (auto& p : lattice)
    for (double& c : p.x_m) c *= 0.0101 / 0.0099;
  CHECK(adapter::meanCoordinationNumber(lattice) == 0);
  CHECK(adapter::meanCoordinationNumber({}) == 0);
}

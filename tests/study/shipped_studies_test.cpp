// The studies shipped in studies/: all valid, carrying the paper's numbers (Tables 1-4, Section 2.9),
// and the soil hash that lets them share one deposit.
#include "demfem/study/study.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

using demfem::study::loadStudy;
using demfem::study::parseStudy;
using demfem::study::soilHash;
using demfem::study::Study;
using demfem::study::StudyKind;

namespace {

const std::filesystem::path kStudies = std::filesystem::path(DEMFEM_SOURCE_DIR) / "studies";

std::vector<std::filesystem::path> shippedStudies() {
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::recursive_directory_iterator(kStudies))
    if (entry.path().extension() == ".json") files.push_back(entry.path());
  std::sort(files.begin(), files.end());
  return files;
}

nlohmann::json readJson(const std::filesystem::path& file) {
  std::ifstream in(file);
  REQUIRE(in);
  return nlohmann::json::parse(in);
}

Study load(const char* name) { return loadStudy(kStudies / name); }

}  // namespace

TEST_CASE("every shipped study validates and round-trips through its file form", "[study]") {
  const std::vector<std::filesystem::path> files = shippedStudies();
  // The paper's cases (3 x 3 soil-bin runs, 2 weights, 2 cone tests) plus the quick case.
  REQUIRE(files.size() >= 14);
  for (const auto& file : files) {
    INFO(file.filename().string());
    try {
      const Study s = loadStudy(file);
      CHECK(s.name == file.stem().string());
      CHECK(parseStudy(demfem::study::toJson(s).dump(), file.string()) == s);
    } catch (const demfem::study::StudyError& e) {
      FAIL(e.what());
    }
  }
}

TEST_CASE("the soil-bin studies carry Table 1's depths and velocities", "[study]") {
  struct Case {
    const char* file;
    double depth_m, velocity_m_s;
  };
  // Table 1: S235 31.19/30.03/32.22 mm/s, PMMA 36.14/28.76/34.09 mm/s at 18/30/42 mm.
  const std::vector<Case> cases{
      {"paper/s235_dem_18.json", 0.018, 0.03119},     {"paper/s235_dem_30.json", 0.030, 0.03003},
      {"paper/s235_dem_42.json", 0.042, 0.03222},     {"paper/s235_coupled_18.json", 0.018, 0.03119},
      {"paper/s235_coupled_30.json", 0.030, 0.03003}, {"paper/s235_coupled_42.json", 0.042, 0.03222},
      {"paper/pmma_coupled_18.json", 0.018, 0.03614}, {"paper/pmma_coupled_30.json", 0.030, 0.02876},
      {"paper/pmma_coupled_42.json", 0.042, 0.03409},
  };
  for (const Case& c : cases) {
    INFO(c.file);
    const Study s = load(c.file);
    REQUIRE(s.tools.size() == 1);
    CHECK(s.tools[0].motion.depth_m == c.depth_m);
    // mm/s -> m/s divides the (inexact) decimal by 1000: equal to the nearest double within 1 ulp.
    CHECK(s.tools[0].motion.velocity_m_s == Approx(c.velocity_m_s).epsilon(1e-15));
    CHECK(s.tools[0].motion.stroke_m == 0.600);  // Section 2.1: 600 mm cylinder stroke
    // Section 2.1 / 2.9: clamp 40 mm, load cell 65 mm and sensor 93 mm below the top.
    CHECK(s.tools[0].constraints.clamp_length_m == 0.040);
    CHECK(s.tools[0].constraints.load_cell_from_top_m == 0.065);
    CHECK(s.tools[0].constraints.sensor_from_top_m == 0.093);
    // A fortieth of the stiffest spring's contact time, the coarsest fraction the convergence
    // study shows converged (docs/paper-reproduction.md, "Time step"); the paper's 7.93e-7 s
    // (Section 2.10.2) is the explicit dem.dt_s the notes name.
    CHECK_FALSE(s.dem.dt_s);
    CHECK(s.dem.criterion == demfem::study::TimeStepCriterion::StiffestSpring);
    CHECK(s.dem.dt_fraction == 0.025);
    // Table 3's 1 ms, halved for the flexible PMMA tool at 30 and 42 mm, where the explicit
    // exchange is unstable at 1 ms (docs/builtin-dem.md, "Blow-up detection").
    const bool flexible_deep = s.tools[0].name == "PMMA" && c.depth_m > 0.020;
    CHECK(s.fem.dt_s == (flexible_deep ? 0.0005 : 0.001));
  }
  CHECK(load("paper/s235_dem_18.json").kind == StudyKind::DemOnly);
  CHECK_FALSE(load("paper/s235_dem_18.json").tools[0].fem.deformable);
  CHECK(load("paper/s235_coupled_18.json").tools[0].fem.deformable);
}

TEST_CASE("the paper's soil: Section 2.9 bin and layers, Table 2 particles, Table 4 friction", "[study]") {
  const Study s = load("paper/pmma_coupled_42.json");
  CHECK(s.soil.bin_length_m == 0.650);
  CHECK(s.soil.bin_width_m == 0.250);
  CHECK(s.soil.fill_height_m == 0.085);
  CHECK(s.soil.diameter_min_m == 0.0095);
  CHECK(s.soil.diameter_max_m == 0.0105);
  REQUIRE(s.soil.layers.size() == 4);
  const double bottoms[] = {0.010, 0.020, 0.030, 0.085};
  for (std::size_t i = 0; i < 4; ++i) CHECK(s.soil.layers[i].bottom_depth_m == bottoms[i]);
  const auto& particle = s.material("layer1");
  CHECK(particle.density_kg_m3 == 2600);
  CHECK(particle.youngs_Pa == 1.12e10);
  CHECK(particle.poisson == 0.3);
  CHECK(particle.yield_Pa == 5.88e5);
  CHECK(s.soil.contact.stiffness_factor == 0.85);
  CHECK(s.soil.contact.damping_factor == 0.5);
  // Table 4 (static, rolling) for a few pairs; Table 2's e_pp = 0.6.
  CHECK(s.interaction("layer1", "layer4").static_friction == 0.07);
  CHECK(s.interaction("layer1", "layer4").rolling_friction == 0.02);
  CHECK(s.interaction("layer3", "layer3").static_friction == 0.21);
  CHECK(s.interaction("layer3", "layer4").rolling_friction == 0.07);
  CHECK(s.interaction("layer4", "layer4").static_friction == 0.3);
  CHECK(s.interaction("layer4", "layer4").rolling_friction == 0.2);
  CHECK(s.interaction("layer2", "layer2").restitution == 0.6);
}

TEST_CASE("the tools: Table 3 FEM data and Section 2.2 sizes", "[study]") {
  const Study pmma = load("paper/pmma_coupled_18.json");
  const auto& p = pmma.tools[0];
  CHECK(p.geometry.length_m == 0.200);
  CHECK(p.geometry.width_m == 0.040);
  CHECK(p.geometry.thickness_m == 0.004);
  CHECK(p.fem.youngs_Pa == 4.06e9);
  CHECK(p.fem.poisson == 0.38);
  CHECK(p.fem.density_kg_m3 == 1220);
  CHECK(p.fem.alpha_s == 0.00055);  // Table 3's 0.55 read as 0.55 ms (docs/architecture.md section 4)
  CHECK(p.fem.beta_per_s == 0);
  CHECK(pmma.material(p.dem_material).youngs_Pa == 7.9e10);  // Table 2, as printed
  const Study steel = load("paper/s235_coupled_30.json");
  const auto& t = steel.tools[0];
  CHECK(t.geometry.thickness_m == 0.003);
  CHECK(t.fem.youngs_Pa == 2.07e11);
  CHECK(t.fem.density_kg_m3 == 7933);
}

TEST_CASE("the calibration-weight and cone studies", "[study]") {
  const Study half = load("weight_drop_0.5kg.json");
  const Study one = load("weight_drop_1kg.json");
  REQUIRE(half.weight_drop);
  REQUIRE(one.weight_drop);
  CHECK(half.weight_drop->mass_kg == 0.5);
  CHECK(one.weight_drop->mass_kg == 1.0);
  CHECK(one.tools[0].fem.youngs_Pa == 4.06e9);  // the PMMA tool (Section 2.10.1)
  const Study cpt = load("cpt.json");
  REQUIRE(cpt.tools.size() == 5);  // five penetrometers 100 mm apart (Section 2.10.3)
  for (std::size_t i = 0; i < 5; ++i) {
    CHECK(cpt.tools[i].motion.velocity_m_s == 0.010);
    CHECK(cpt.tools[i].motion.start_z_m == Approx(0.125 + 0.1 * static_cast<double>(i)).margin(1e-15));
  }
  CHECK(load("cpt_unlayered.json").soil.layers.size() == 1);
}

TEST_CASE("the soil hash is stable and depends on the soil only", "[study]") {
  // FNV-1a 64 reference vectors (the algorithm's published test values).
  CHECK(demfem::study::fnv1a64("") == 0xcbf29ce484222325ull);
  CHECK(demfem::study::fnv1a64("a") == 0xaf63dc4c8601ec8cull);
  CHECK(demfem::study::fnv1a64("foobar") == 0x85944171f73967e8ull);

  const std::string reference = soilHash(load("paper/pmma_coupled_18.json"));
  CHECK(reference.size() == 16);
  // Same soil, other tools, depths, kinds and tool materials: one deposit serves them all.
  // (cpt.json steps at the paper's explicit 7.93e-7 s, and the DEM step is part of the soil's hash.)
  for (const char* other : {"paper/pmma_coupled_42.json", "paper/s235_coupled_30.json", "paper/s235_dem_18.json"}) {
    INFO(other);
    CHECK(soilHash(load(other)) == reference);
  }
  nlohmann::json doc = readJson(kStudies / "paper/pmma_coupled_18.json");
  const auto hashOf = [](const nlohmann::json& d) { return soilHash(parseStudy(d.dump(), "h.json")); };
  // Not sensitive to tools, notes, key order or the order of the interaction table.
  nlohmann::json tool_change = doc;
  tool_change["tools"][0]["fem"]["E_Pa"] = 3e9;
  tool_change["notes"] = "changed";
  tool_change["soil"]["materials"][5]["E_Pa"] = 3e9;  // pmma: the tool's DEM material
  auto& table = tool_change["soil"]["interactions"];
  std::reverse(table.begin(), table.end());
  CHECK(hashOf(tool_change) == reference);
  // Sensitive to what the deposition sees.
  nlohmann::json friction = doc;
  friction["soil"]["interactions"][9]["static_friction"] = 0.31;
  CHECK(hashOf(friction) != reference);
  nlohmann::json seed = doc;
  seed["soil"]["deposition"]["seed"] = 2;
  CHECK(hashOf(seed) != reference);
  nlohmann::json density = doc;
  density["soil"]["deposition"]["bulk_density_kg_m3"] = 1500;  // the density protocol's target
  CHECK(hashOf(density) != reference);
  nlohmann::json wall = doc;
  wall["soil"]["materials"][4]["E_Pa"] = 2.05e11;  // steel: the bin
  CHECK(hashOf(wall) != reference);
  nlohmann::json threads = doc;
  threads["dem"]["threads"] = 2;  // one soil for every run's core count
  CHECK(hashOf(threads) == reference);
  nlohmann::json deposition_threads = doc;
  deposition_threads["soil"]["deposition"]["threads"] = 2;  // the packing's bits depend on them
  CHECK(hashOf(deposition_threads) != reference);
  // Both backends run the same soil; another deposition backend makes another soil.
  const nlohmann::json quick = readJson(kStudies / "quick_liggghts.json");
  nlohmann::json run_backend = quick, deposition_backend = quick;
  run_backend["dem"]["backend"] = run_backend["dem"]["backend"] == "liggghts" ? "builtin" : "liggghts";
  deposition_backend["soil"]["deposition"]["backend"] = "liggghts";
  CHECK(hashOf(run_backend) == hashOf(quick));
  CHECK(hashOf(deposition_backend) != hashOf(quick));
  CHECK(soilHash(load("cpt_unlayered.json")) != reference);
  CHECK_THROWS_AS(soilHash(load("weight_drop_1kg.json")), std::invalid_argument);
}

// Study-file loader: every kind of problem is reported with its JSON path, all at once; units are
// converted once; cross-field rules hold. Mutations start from studies/quick.json.
#include "demfem/study/backend_capabilities.hpp"
#include "demfem/study/study.hpp"

#include "source_files.hpp"

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <numbers>
#include <sstream>
#include <string>
#include <vector>

using demfem::study::Issue;
using demfem::study::parseStudy;
using demfem::study::Study;
using demfem::study::StudyError;
using nlohmann::json;

namespace {

using demfem::study::testing::kSource;
using demfem::study::testing::readText;

json quick() { return json::parse(readText(kSource / "studies/quick.json")); }
json paper(const char* name) { return json::parse(readText(kSource / "studies" / name)); }

// Issues reported for `doc` (empty if it is valid).
std::vector<Issue> issuesOf(const json& doc) {
  try {
    parseStudy(doc.dump(), "mutated.json");
  } catch (const StudyError& e) {
    return e.issues();
  }
  return {};
}

// `doc` has exactly one problem, at `path`, and its message starts with `message`.
void requireSingleIssue(const json& doc, const std::string& path, const std::string& message) {
  const std::vector<Issue> issues = issuesOf(doc);
  INFO("path " << path);
  for (const Issue& i : issues) INFO(i.path << ": " << i.message);
  REQUIRE(issues.size() == 1);
  CHECK(issues[0].path == path);
  CHECK(issues[0].message.rfind(message, 0) == 0);
  if (issues[0].message.rfind(message, 0) != 0) WARN(issues[0].message);
}

}  // namespace

TEST_CASE("quick study is valid as shipped", "[study]") { CHECK(issuesOf(quick()).empty()); }

TEST_CASE("a value out of range is reported with its path and the offending value", "[study]") {
  json doc = quick();
  doc["tools"][0]["fem"]["E_Pa"] = -4.06e9;
  requireSingleIssue(doc, "/tools/0/fem/E_Pa", "must be >= 1000 and <= 1e13, got -4.06e9");
  doc = quick();
  doc["tools"][0]["fem"]["nu"] = 0.5;  // nu < 0.5: an elastic solid is not incompressible
  requireSingleIssue(doc, "/tools/0/fem/nu", "must be > -1 and < 0.5, got 0.5");
  doc = quick();
  doc["soil"]["interactions"][0]["restitution"] = 0.0;  // K2 = K1 / e^2 needs e > 0
  requireSingleIssue(doc, "/soil/interactions/0/restitution", "must be > 0 and <= 1, got 0");
}

TEST_CASE("an unknown key is reported and a close misspelling gets a suggestion", "[study]") {
  json doc = quick();
  doc["dem"]["colour"] = "red";
  requireSingleIssue(doc, "/dem/colour", "unknown key");
  doc = quick();
  doc["tools"][0]["motion"]["stroke_m"] = 0.05;  // the key carries the unit: mm here
  requireSingleIssue(doc, "/tools/0/motion/stroke_m", "unknown key (did you mean \"stroke_mm\"?)");
}

TEST_CASE("a value of the wrong type is reported with what was expected", "[study]") {
  json doc = quick();
  doc["tools"][0]["motion"]["depth_mm"] = "18";
  requireSingleIssue(doc, "/tools/0/motion/depth_mm", "must be a number in mm, > 0 and <= 1e5, got string \"18\"");
  doc = quick();
  doc["dem"]["threads"] = 1.5;
  requireSingleIssue(doc, "/dem/threads", "must be an integer >= 1 and <= 1024, got number 1.5");
}

TEST_CASE("a missing required key is reported with its expected type and unit", "[study]") {
  json doc = quick();
  doc["soil"]["particles"].erase("diameter_max_mm");
  requireSingleIssue(doc, "/soil/particles/diameter_max_mm", "missing required key (a number in mm, >= 0.001 and <= 1000)");
  doc = quick();
  doc["tools"][0]["fem"].erase("alpha_s");  // Rayleigh alpha: physics, no default
  requireSingleIssue(doc, "/tools/0/fem/alpha_s", "missing required key (a number in s, >= 0 and <= 1)");
}

TEST_CASE("a bad enumeration string lists the allowed values", "[study]") {
  json doc = quick();
  doc["soil"]["contact"]["normal"] = "hertz";
  requireSingleIssue(doc, "/soil/contact/normal",
                     "must be one of \"edem-hysteretic\", \"hooke\", \"hooke-hysteresis\"; got \"hertz\"");
  doc = quick();
  doc["kind"] = "coupled-dem";
  const std::vector<Issue> issues = issuesOf(doc);
  REQUIRE(issues.size() == 1);
  CHECK(issues[0].path == "/kind");
}

TEST_CASE("the five-mistakes file yields exactly its five messages with their paths", "[study]") {
  const std::filesystem::path file = kSource / "tests/study/data/five_mistakes.json";
  try {
    demfem::study::loadStudy(file);
    FAIL("five_mistakes.json was accepted");
  } catch (const StudyError& e) {
    std::vector<Issue> issues = e.issues();
    std::sort(issues.begin(), issues.end(), [](const Issue& a, const Issue& b) { return a.path < b.path; });
    REQUIRE(issues.size() == 5);
    CHECK(issues[0].path == "/dem/colour");
    CHECK(issues[1].path == "/soil/contact/normal");
    CHECK(issues[2].path == "/soil/particles/diameter_max_mm");
    CHECK(issues[3].path == "/tools/0/fem/E_Pa");
    CHECK(issues[3].message == "must be >= 1000 and <= 1e13, got -4.06e9");
    CHECK(issues[4].path == "/tools/0/motion/depth_mm");
    // what() is one "FILE: PATH: MESSAGE" line per problem.
    const std::string what = e.what();
    CHECK(what.find(file.string() + ": /tools/0/fem/E_Pa: must be >= 1000 and <= 1e13, got -4.06e9") != std::string::npos);
    CHECK(std::count(what.begin(), what.end(), '\n') == 4);
  }
}

TEST_CASE("keys with units are converted to SI once", "[study]") {
  const Study s = parseStudy(quick().dump(), "quick.json");
  CHECK(s.tools[0].motion.depth_m == 0.018);  // exact: 18 / 1000 is the double nearest 0.018
  CHECK(s.tools[0].motion.velocity_m_s == Approx(0.03614).epsilon(1e-15));  // 36.14 / 1000, within 1 ulp
  CHECK(s.tools[0].geometry.thickness_m == 0.004);
  CHECK(s.soil.diameter_min_m == 0.0095);
  CHECK(s.tools[0].fem.alpha_s == 0.00055);
  CHECK(s.tools[0].motion.center_x_m == 0.060);  // default: centre line of the 120 mm bin
  const Study cpt = demfem::study::loadStudy(kSource / "studies/cpt.json");
  CHECK(cpt.tools[0].geometry.cone_area_m2 == Approx(5e-4).epsilon(1e-15));
  CHECK(cpt.tools[0].geometry.cone_angle_rad == Approx(std::numbers::pi / 3).epsilon(1e-15));
}

TEST_CASE("a JSON syntax error gives line and column", "[study]") {
  const std::string text = "{\n  \"name\": \"x\",\n  \"kind\": coupled\n}\n";
  try {
    parseStudy(text, "broken.json");
    FAIL("syntax error accepted");
  } catch (const StudyError& e) {
    REQUIRE(e.issues().size() == 1);
    CHECK(e.issues()[0].path == "/kind");  // where the parser was
    CHECK(e.issues()[0].message.rfind("line 3, column 11: ", 0) == 0);
    CHECK(std::string(e.what()).rfind("broken.json: /kind: line 3, column 11: ", 0) == 0);
  }
}

TEST_CASE("a duplicated key is reported instead of silently keeping the last value", "[study]") {
  std::string text = quick().dump(2);
  const std::string key = "\"fill_height_mm\": 50";
  text.replace(text.find(key), key.size(), key + ",\n    \"fill_height_mm\": 60");
  const std::vector<Issue> issues = [&] {
    try {
      parseStudy(text, "dup.json");
    } catch (const StudyError& e) {
      return e.issues();
    }
    return std::vector<Issue>{};
  }();
  REQUIRE_FALSE(issues.empty());
  CHECK(issues[0].path == "/soil/fill_height_mm");
  CHECK(issues[0].message.rfind("duplicate key", 0) == 0);
}

TEST_CASE("layers must tile the soil from the surface to the fill height", "[study]") {
  json doc = quick();
  doc["soil"]["layers"][2]["top_depth_mm"] = 25;  // gap 20-25 mm
  requireSingleIssue(doc, "/soil/layers/2/top_depth_mm", "must equal the bottom of layer 1 (20 mm)");
  doc = quick();
  doc["soil"]["layers"][3]["bottom_depth_mm"] = 45;  // fill height is 50 mm
  requireSingleIssue(doc, "/soil/layers/3/bottom_depth_mm", "the last layer must end at fill_height_mm (50 mm)");
  doc = quick();
  doc["soil"]["layers"][0]["top_depth_mm"] = 2;
  requireSingleIssue(doc, "/soil/layers/0/top_depth_mm", "the first layer must start at the surface");
}

TEST_CASE("the interaction table covers every particle and particle-wall pair exactly once", "[study]") {
  json doc = quick();
  auto& table = doc["soil"]["interactions"];
  // Remove the (layer3, pmma) entry.
  for (std::size_t i = 0; i < table.size(); ++i) {
    if (table[i]["materials"] == json{"layer3", "pmma"}) {
      table.erase(i);
      break;
    }
  }
  requireSingleIssue(doc, "/soil/interactions", "missing the pair (\"layer3\", \"pmma\")");

  doc = quick();
  json duplicate = doc["soil"]["interactions"][1];
  std::swap(duplicate["materials"][0], duplicate["materials"][1]);  // same pair, other order
  doc["soil"]["interactions"].push_back(duplicate);
  const std::size_t last = doc["soil"]["interactions"].size() - 1;
  requireSingleIssue(doc, "/soil/interactions/" + std::to_string(last) + "/materials",
                     "the pair (\"layer2\", \"layer1\") is already given at /soil/interactions/1");

  doc = quick();
  json walls = doc["soil"]["interactions"][0];
  walls["materials"] = {"steel", "pmma"};
  doc["soil"]["interactions"].push_back(walls);
  requireSingleIssue(doc, "/soil/interactions/" + std::to_string(last) + "/materials",
                     "\"steel\" and \"pmma\" are both walls");
}

TEST_CASE("materials are referenced by name and every defined material is used", "[study]") {
  json doc = quick();
  doc["tools"][0]["dem_material"] = "acrylic";
  const std::vector<Issue> issues = issuesOf(doc);
  // The tool's material is undefined, so "pmma" is unused and its pairs are walls of nothing.
  REQUIRE_FALSE(issues.empty());
  CHECK(issues[0].path == "/tools/0/dem_material");
  CHECK(issues[0].message.rfind("material \"acrylic\" is not defined", 0) == 0);
}

TEST_CASE("constraints lie on the free part of the tool and the depth fits the soil and tool", "[study]") {
  json doc = quick();
  doc["tools"][0]["constraints"]["load_cell_from_top_mm"] = 30;  // inside the 40 mm clamp
  requireSingleIssue(doc, "/tools/0/constraints/load_cell_from_top_mm", "must lie on the free part of the tool");
  doc = quick();
  doc["tools"][0]["constraints"]["sensor_from_top_mm"] = 200;  // at the tip
  requireSingleIssue(doc, "/tools/0/constraints/sensor_from_top_mm", "must lie on the free part of the tool");
  doc = quick();
  doc["tools"][0]["constraints"]["clamp_length_mm"] = 200;
  const std::vector<Issue> clamp = issuesOf(doc);
  REQUIRE_FALSE(clamp.empty());
  CHECK(clamp[0].path == "/tools/0/constraints/clamp_length_mm");
  doc = quick();
  doc["tools"][0]["motion"]["depth_mm"] = 50;  // fill height 50 mm
  requireSingleIssue(doc, "/tools/0/motion/depth_mm", "must be < soil.fill_height_mm (50 mm)");
  doc = quick();
  doc["tools"][0]["constraints"]["clamp_length_mm"] = 190;  // 10 mm free: 18 mm depth reaches the clamp
  doc["tools"][0]["constraints"]["load_cell_from_top_mm"] = 192;
  doc["tools"][0]["constraints"]["sensor_from_top_mm"] = 195;
  requireSingleIssue(doc, "/tools/0/motion/depth_mm", "must be < the tool length minus the clamp (10 mm)");
  doc = quick();
  doc["tools"][0]["motion"]["stroke_mm"] = 200;  // front face 80 mm + 200 mm > 250 mm bin
  requireSingleIssue(doc, "/tools/0/motion/start_z_mm", "the tool's path (z from 76 mm to 280 mm)");
  doc = quick();
  doc["tools"][0]["motion"]["start_z_mm"] = 3;  // the 4 mm plate's back face would be outside
  requireSingleIssue(doc, "/tools/0/motion/start_z_mm", "the tool's path (z from -1 mm to 53 mm)");
}

TEST_CASE("particle sizes are ordered", "[study]") {
  json doc = quick();
  doc["soil"]["particles"]["diameter_min_mm"] = 11;
  requireSingleIssue(doc, "/soil/particles/diameter_min_mm", "must be <= diameter_max_mm (10.5 mm), got 11 mm");
}

TEST_CASE("sections and keys follow the study kind and the chosen models", "[study]") {
  json doc = quick();
  doc["kind"] = "dem-only";  // the rigid tool of a DEM-only study is not integrated in time
  doc["tools"][0]["fem"].erase("beta_per_s");
  requireSingleIssue(doc, "/tools/0/fem/alpha_s", "does not apply: a rigid tool is not integrated in time");
  doc = quick();
  doc["kind"] = "weight-drop";
  const std::vector<Issue> drop = issuesOf(doc);
  const auto has = [&](const std::string& path) {
    return std::any_of(drop.begin(), drop.end(), [&](const Issue& i) { return i.path == path; });
  };
  CHECK(has("/weight_drop"));  // required for this kind
  CHECK(has("/soil"));         // forbidden for this kind
  CHECK(has("/tools/0/motion"));
  doc = quick();
  doc["soil"]["contact"]["rolling"] = "none";  // then no rolling friction may be given
  const std::vector<Issue> rolling = issuesOf(doc);
  REQUIRE(rolling.size() == doc["soil"]["interactions"].size());
  CHECK(rolling[0].path == "/soil/interactions/0/rolling_friction");
  doc = quick();
  doc["dem"]["dt_s"] = 1e-6;  // explicit step and a criterion contradict each other
  const std::vector<Issue> dt = issuesOf(doc);
  REQUIRE(dt.size() == 2);
  CHECK(dt[0].path == "/dem/criterion");
  CHECK(dt[1].path == "/dem/dt_fraction");
}

TEST_CASE("a backend that lacks the study's contact laws is named with each law, also when it only deposits", "[study]") {
  using demfem::study::BackendCapabilities;
  using namespace demfem::study;
  const BackendCapabilities all{"full", true, {NormalModel::EdemHysteretic, NormalModel::Hooke},
                                {CohesionModel::None, CohesionModel::EdemLinear}, {RollingModel::EdemStandard, RollingModel::Epsd}, {}, true};
  const BackendCapabilities hooke{"hooke-only", true, {NormalModel::Hooke}, {CohesionModel::None, CohesionModel::Sjkr},
                                  {RollingModel::Cdt}, {}, false};
  // quick.json: edem-hysteretic, edem-linear, epsd; deposited by "builtin".
  Study s = parseStudy(quick().dump(), "quick.json");
  s.dem.backend = "full";
  const std::vector<Issue> unknown = backendIssues(s, {all, hooke});
  REQUIRE(unknown.size() == 1);  // the deposition backend is not in this registry
  CHECK(unknown[0].path == "/soil/deposition/backend");
  BackendCapabilities builtin = all;
  builtin.name = "builtin";
  s.dem.backend = "builtin";
  CHECK(backendIssues(s, {builtin, hooke}).empty());
  s.dem.backend = "hooke-only";
  const std::vector<Issue> laws = backendIssues(s, {builtin, hooke});
  REQUIRE(laws.size() == 3);
  CHECK(laws[0].path == "/soil/contact/normal");
  CHECK(laws[0].message == "\"edem-hysteretic\" is not available in the hooke-only backend; use \"hooke\"");
  CHECK(laws[1].message == "\"edem-linear\" is not available in the hooke-only backend; use \"sjkr\"");
  s.dem.backend = "nowhere";
  const std::vector<Issue> missing = backendIssues(s, {builtin, hooke});
  REQUIRE(missing.size() == 1);
  CHECK(missing[0].path == "/dem/backend");
  CHECK(missing[0].message == "unknown backend \"nowhere\" (this build offers builtin, hooke-only)");
  // The density protocol is the built-in deposition's: another deposition backend stating one is refused.
  s.dem.backend = "builtin";
  s.soil.bulk_density_kg_m3 = 1500;
  CHECK(backendIssues(s, {builtin, hooke}).empty());
  BackendCapabilities other = all;
  other.name = "other";
  s.soil.deposition_backend = "other";
  const std::vector<Issue> density = backendIssues(s, {builtin, other});
  REQUIRE(density.size() == 1);
  CHECK(density[0].path == "/soil/deposition/bulk_density_kg_m3");
  CHECK(density[0].message.find("builtin backend only") != std::string::npos);
}

TEST_CASE("the effective study round-trips through its file form", "[study]") {
  const Study s = parseStudy(quick().dump(), "quick.json");
  const Study again = parseStudy(demfem::study::toJson(s).dump(), "quick.json");
  CHECK(again == s);
}

TEST_CASE("describe lists effective values in the file's units", "[study]") {
  const Study s = parseStudy(quick().dump(), "quick.json");
  const std::string text = demfem::study::describe(s);
  CHECK(text.find("/tools/0/motion/depth_mm = 18 mm\n") != std::string::npos);
  CHECK(text.find("/tools/0/fem/E_Pa = 4.06e9 Pa\n") != std::string::npos);
  CHECK(text.find("/tools/0/fem/alpha_s = 0.00055 s\n") != std::string::npos);
  CHECK(text.find("/tools/0/motion/center_x_mm = 60 mm\n") != std::string::npos);  // default shown
  CHECK(text.find("/soil/interactions/0/materials = [\"layer1\",\"layer1\"]\n") != std::string::npos);
  CHECK(text.find("/output/directory = out/quick\n") != std::string::npos);
}

TEST_CASE("material and interaction look-ups are symmetric and reject unknown names", "[study]") {
  const Study s = parseStudy(paper("paper/pmma_coupled_30.json").dump(), "pmma_coupled_30.json");
  CHECK(s.interaction("layer4", "layer3").static_friction == 0.21);  // Table 4
  CHECK(&s.interaction("layer3", "layer4") == &s.interaction("layer4", "layer3"));
  CHECK(s.material("layer1").yield_Pa == 5.88e5);
  CHECK_THROWS_AS(s.material("sand"), std::out_of_range);
  CHECK_THROWS_AS(s.interaction("steel", "pmma"), std::out_of_range);
}

TEST_CASE("cones stay inside the bin and apart, and move only down", "[study]") {
  json doc = paper("cpt.json");
  CHECK(issuesOf(doc).empty());
  doc["tools"][1]["motion"]["start_z_mm"] = 150;  // 25 mm from cone 1; a 5 cm^2 cone is 25.2 mm wide
  requireSingleIssue(doc, "/tools/1/motion", "the cone overlaps the cone of /tools/0");
  doc = paper("cpt.json");
  doc["tools"][0]["motion"]["center_x_mm"] = 10;  // radius 12.6 mm: crosses the side wall
  requireSingleIssue(doc, "/tools/0/motion/center_x_mm", "the tool (x from -2.61566");
  doc = paper("cpt.json");
  doc["tools"][0]["motion"]["stroke_mm"] = 55;
  requireSingleIssue(doc, "/tools/0/motion/stroke_mm", "does not apply: a cone moves straight down");
  doc = paper("cpt.json");
  doc["tools"][0]["geometry"] = {{"kind", "plate"}, {"length_mm", 200}, {"width_mm", 40}, {"thickness_mm", 4}};
  const std::vector<Issue> plate = issuesOf(doc);
  REQUIRE_FALSE(plate.empty());
  CHECK(plate[0].path == "/tools/0/geometry/kind");
  CHECK(plate[0].message == "a cone-penetration study needs geometry kind \"cone\"");
}

TEST_CASE("external meshes and matrices must exist; matrices carry the material", "[study]") {
  json doc = quick();
  doc["tools"][0]["geometry"] = {{"kind", "gmsh"}, {"length_mm", 200}, {"mesh_file", "no_such_tool.msh"}};
  const std::vector<Issue> gmsh = issuesOf(doc);
  REQUIRE(gmsh.size() == 1);
  CHECK(gmsh[0].path == "/tools/0/geometry/mesh_file");
  CHECK(gmsh[0].message.rfind("file not found: ", 0) == 0);
  // The study file itself stands in for an existing matrix file: only existence is checked here.
  doc = quick();
  doc["tools"][0]["geometry"] = {{"kind", "matrix-market"},
                                 {"length_mm", 200},
                                 {"mass_file", "quick.json"},
                                 {"stiffness_file", "quick.json"},
                                 {"keypoint_file", "quick.json"}};
  const std::vector<Issue> matrices = [&] {
    try {
      parseStudy(doc.dump(), (kSource / "studies/mutated.json").string());
    } catch (const StudyError& e) {
      return e.issues();
    }
    return std::vector<Issue>{};
  }();
  // E, nu, density and element order are in the matrices already.
  REQUIRE(matrices.size() == 4);
  for (const Issue& i : matrices) CHECK(i.message.find("already contain") != std::string::npos);
}

TEST_CASE("a number beyond the double range is reported with line, column and JSON path", "[study]") {
  const std::string text = R"({"name": "x", "kind": "coupled",
  "fem": {"dt_s": 1e400}})";
  try {
    parseStudy(text, "huge.json");
    FAIL("1e400 accepted");
  } catch (const StudyError& e) {
    REQUIRE(e.issues().size() == 1);
    CHECK(e.issues()[0].path == "/fem/dt_s");
    CHECK_THAT(e.issues()[0].message, Catch::StartsWith("line 2, column ") && Catch::Contains("1e400"));
  }
}

TEST_CASE("bytes that are not UTF-8 are reported, and every message is valid UTF-8", "[study]") {
  for (const std::string& bad : {std::string("\xff\xfe"), std::string("\xc3"), std::string("a\xe2\x82")}) {
    const std::string text = "{\"name\": \"" + bad + "\", \"kind\": \"coupled\"}";
    try {
      parseStudy(text, "latin1-\xe9.json");
      FAIL("invalid UTF-8 accepted");
    } catch (const StudyError& e) {
      REQUIRE(e.issues().size() == 1);
      CHECK(e.issues()[0].path == "/name");
      CHECK_THAT(e.issues()[0].message, Catch::Contains("UTF-8"));
      // Dumping the report (what `validate --json` does) must not throw on what the messages quote.
      CHECK_NOTHROW(json({{"file", e.file()}, {"message", e.issues()[0].message}, {"what", e.what()}}).dump());
      CHECK_THAT(e.file(), Catch::Contains("\\xE9"));
    }
  }
  // A long string value cut for a message is cut between characters, not inside one.
  json doc = quick();
  doc["soil"]["bin"]["length_mm"] = std::string(36, 'a') + "\xc3\xa9\xc3\xa9\xc3\xa9\xc3\xa9";
  const auto issues = issuesOf(doc);
  REQUIRE(issues.size() == 1);
  CHECK_NOTHROW(json(issues[0].message).dump());
  CHECK_THAT(issues[0].message, Catch::Contains(std::string(36, 'a') + "..."));
}

TEST_CASE("nesting is capped at 64 levels before it costs memory", "[study]") {
  const std::size_t depth = 100000;
  const std::string text = "{\"notes\": " + std::string(depth, '[') + std::string(depth, ']') + "}";
  try {
    parseStudy(text, "deep.json");
    FAIL("deep nesting accepted");
  } catch (const StudyError& e) {
    REQUIRE(e.issues().size() == 1);
    CHECK_THAT(e.issues()[0].message, Catch::Contains("nested deeper than 64"));
    CHECK(e.issues()[0].path.size() < 200);
  }
}

TEST_CASE("numbers outside their physical range are refused at validation, naming the key", "[study]") {
  json doc = quick();
  doc["dem"]["threads"] = 1000000000000LL;
  requireSingleIssue(doc, "/dem/threads", "must be >= 1 and <= 1024, got 1000000000000");
  doc = quick();
  doc["soil"]["bin"]["width_mm"] = 1e300;
  requireSingleIssue(doc, "/soil/bin/width_mm", "must be > 0 and <= 1e5, got 1e300");
  doc = quick();
  doc["fem"]["dt_s"] = 1e-300;
  requireSingleIssue(doc, "/fem/dt_s", "must be >= 1e-9 and <= 1, got 1e-300");
}

TEST_CASE("a study too large for the programs is refused with the key that makes it so", "[study]") {
  json doc = quick();
  doc["soil"]["particles"]["diameter_min_mm"] = 0.01;
  doc["soil"]["particles"]["diameter_max_mm"] = 0.01;
  requireSingleIssue(doc, "/soil/particles/diameter_min_mm", "the bin would hold about");
  doc = quick();
  doc["tools"][0]["geometry"]["keypoint_spacing_mm"] = 1e-6;
  requireSingleIssue(doc, "/tools/0/geometry/keypoint_spacing_mm", "gives about");
  doc = quick();
  doc["fem"]["dt_s"] = 1e-8;  // in range, but 1e9 FEM steps for the quick study's stroke
  requireSingleIssue(doc, "/fem/dt_s", "gives");
  doc = quick();
  doc["coupling"]["max_simulate_s"] = 1e-6;  // below the FEM step: every simulate call would be refused
  requireSingleIssue(doc, "/coupling/max_simulate_s", "must be >= fem.dt_s");
}

TEST_CASE("an ipc endpoint that names an existing file is refused: binding would delete it", "[study]") {
  const auto file = std::filesystem::temp_directory_path() / "demfem-study-endpoint-test.txt";
  { std::ofstream(file) << "keep me\n"; }
  json doc = quick();
  doc["coupling"]["endpoint"] = "ipc://" + file.string();
  requireSingleIssue(doc, "/coupling/endpoint", "the ipc path");
  doc["coupling"]["endpoint"] = "ipc://" + file.string() + ".absent";
  CHECK(issuesOf(doc).empty());
  doc["coupling"]["endpoint"] = "x";
  requireSingleIssue(doc, "/coupling/endpoint", "must start with");
  std::filesystem::remove(file);
}

TEST_CASE("the model extensions a diagnosis adds are study keys with ranges, absent = today's model", "[study]") {
  const Study plain = parseStudy(paper("weight_drop_1kg.json").dump(), "weight_drop_1kg.json");
  CHECK_FALSE(plain.tools[0].constraints.clamp_rotational_stiffness_Nm_per_rad);
  CHECK(plain.tools[0].sensors.force_gain == 1.0);
  CHECK(plain.tools[0].sensors.deformation_gain == 1.0);
  json doc = paper("weight_drop_1kg.json");
  doc["tools"][0]["constraints"]["clamp_rotational_stiffness_Nm_per_rad"] = 25.0;
  doc["tools"][0]["sensors"] = {{"force_gain", 0.95}, {"deformation_gain", 1.1}};
  doc["tools"][0]["fem"]["beta_per_s"] = 0.4;
  const Study extended = parseStudy(doc.dump(), "extended.json");
  CHECK(extended.tools[0].constraints.clamp_rotational_stiffness_Nm_per_rad == 25.0);
  CHECK(extended.tools[0].sensors.force_gain == 0.95);
  CHECK(extended.tools[0].sensors.deformation_gain == 1.1);
  CHECK(parseStudy(toJson(extended).dump(), "extended.json") == extended);
  doc["tools"][0]["constraints"]["clamp_rotational_stiffness_Nm_per_rad"] = 0;
  requireSingleIssue(doc, "/tools/0/constraints/clamp_rotational_stiffness_Nm_per_rad", "must be > 0 and <= 1e9, got 0");
  doc["tools"][0]["constraints"]["clamp_rotational_stiffness_Nm_per_rad"] = 25.0;
  doc["tools"][0]["sensors"]["force_gain"] = -1;
  requireSingleIssue(doc, "/tools/0/sensors/force_gain", "must be > 0 and <= 100, got -1");
  json rigid = paper("paper/s235_dem_18.json");
  rigid["tools"][0]["sensors"] = {{"force_gain", 0.95}};
  requireSingleIssue(rigid, "/tools/0/sensors", "does not apply");
}

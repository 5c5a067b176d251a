// Translation of a study into LIGGGHTS commands: no LIGGGHTS run needed.
#include "demfem/backends/liggghts/input_deck.hpp"
#include "small_study.hpp"

#include "demfem/adapter/coupling_api.hpp"
#include "demfem/study/tool_motion.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <sstream>

using namespace demfem;
using liggghts::testing::smallStudy;

namespace {

const std::string& lineStarting(const std::vector<std::string>& lines, const std::string& start) {
  for (const auto& line : lines)
    if (line.rfind(start, 0) == 0) return line;
  FAIL("no command starts with \"" << start << "\"");
  throw std::logic_error("unreachable");
}

adapter::ErrorCode errorCodeOf(const study::Study& s) {
  try {
    liggghts::translateStudy(s, "stl");
  } catch (const adapter::CouplingError& e) {
    return e.code();
  }
  return adapter::ErrorCode::Internal;  // not thrown: no code
}

}  // namespace

TEST_CASE("layers become atom types and interactions per-type-pair tables", "[liggghts]") {
  auto s = smallStudy();
  s.soil.materials.push_back({"subsoil", 2700, 8e6, 0.25, 0});
  s.soil.layers = {{"soil", 0.0, 0.015}, {"subsoil", 0.015, 0.04}};
  s.soil.interactions.push_back({"subsoil", "subsoil", 0.4, 0.7, 0.2, 0.0});
  s.soil.interactions.push_back({"soil", "subsoil", 0.45, 0.6, 0.15, 0.0});
  s.soil.interactions.push_back({"subsoil", "bin_steel", 0.5, 0.3, 0.05, 0.0});
  s.soil.interactions.push_back({"subsoil", "tool_steel", 0.5, 0.3, 0.05, 0.0});
  const auto deck = liggghts::translateStudy(s, "stl");
  // types: 1 soil, 2 subsoil (layer order), 3 bin_steel, 4 tool_steel
  CHECK(deck.atom_type_count == 4);
  CHECK(lineStarting(deck.setup, "fix m_E ") == "fix m_E all property/global youngsModulus peratomtype 5000000 8000000 200000000 200000000");
  // row-major 4 x 4 friction table from Table-4-style interactions; wall-tool never touch -> 0
  CHECK(lineStarting(deck.setup, "fix m_mu ") ==
        "fix m_mu all property/global coefficientFriction peratomtypepair 4 "
        "0.5 0.59999999999999998 0.40000000000000002 0.40000000000000002 "
        "0.59999999999999998 0.69999999999999996 0.29999999999999999 0.29999999999999999 "
        "0.40000000000000002 0.29999999999999999 0 0 "
        "0.40000000000000002 0.29999999999999999 0 0");
  CHECK(lineStarting(deck.setup, "pair_style") == "pair_style gran model hooke tangential history rolling_friction cdt");
  CHECK(lineStarting(deck.tools, "fix tool_wall") ==
        "fix tool_wall all wall/gran model hooke tangential history rolling_friction cdt mesh n_meshes 1 meshes tool0 "
        "store_force_contact_stress yes");
  // every layer gets its own insertion of its own type
  CHECK(std::count_if(deck.deposition.begin(), deck.deposition.end(),
                      [](const std::string& l) { return l.find("insert/pack") != std::string::npos; }) == 2);
  CHECK(lineStarting(deck.deposition, "fix layer1_size0 ").find("atom_type 2 density constant 2700") != std::string::npos);
}

TEST_CASE("hooke/hysteresis and cohesion models add their LIGGGHTS property tables", "[liggghts]") {
  auto s = smallStudy();
  s.soil.contact.normal = study::NormalModel::HookeHysteresis;
  s.soil.contact.cohesion = study::CohesionModel::Sjkr2;
  s.soil.contact.rolling = study::RollingModel::Epsd;
  s.soil.contact.tangential_history = false;
  const auto deck = liggghts::translateStudy(s, "stl");
  CHECK(lineStarting(deck.setup, "pair_style") ==
        "pair_style gran model hooke/hysteresis tangential no_history cohesion sjkr2 rolling_friction epsd");
  CHECK(lineStarting(deck.setup, "fix m_k2 ").find("coefficientMaxElasticStiffness peratomtypepair 3 2 2 2") !=
        std::string::npos);
  CHECK(lineStarting(deck.setup, "fix m_phi ").find("coefficientPlasticityDepth") != std::string::npos);
  CHECK(lineStarting(deck.setup, "fix m_coh ").find("cohesionEnergyDensity") != std::string::npos);
  CHECK(lineStarting(deck.setup, "fix m_etar ").find("coefficientRollingViscousDamping") != std::string::npos);
}

TEST_CASE("EDEM-only contact laws and values LIGGGHTS would abort on are refused before LIGGGHTS runs", "[liggghts]") {
  auto s = smallStudy();
  s.soil.contact.normal = study::NormalModel::EdemHysteretic;
  CHECK(errorCodeOf(s) == adapter::ErrorCode::Unsupported);
  s = smallStudy();
  s.soil.contact.cohesion = study::CohesionModel::EdemLinear;
  CHECK(errorCodeOf(s) == adapter::ErrorCode::Unsupported);
  s = smallStudy();
  s.soil.contact.rolling = study::RollingModel::EdemStandard;
  CHECK(errorCodeOf(s) == adapter::ErrorCode::Unsupported);
  s = smallStudy();
  s.soil.interactions[0].restitution = 0;  // LIGGGHTS takes log(e)
  CHECK(errorCodeOf(s) == adapter::ErrorCode::BadRequest);
  s = smallStudy();
  s.soil.interactions.pop_back();  // soil-tool pair missing
  CHECK(errorCodeOf(s) == adapter::ErrorCode::BadRequest);
  s = smallStudy();
  s.tools[0].geometry.kind = study::GeometryKind::Gmsh;  // its keypoints come from the FEM model
  CHECK(errorCodeOf(s) == adapter::ErrorCode::Unsupported);
}

TEST_CASE("the deck steps at the shared DEM step of the study's criterion, divided to the FEM step", "[liggghts]") {
  auto s = smallStudy();
  const auto deckStep = [](const study::Study& st) { return liggghts::translateStudy(st, "stl").time_step_s; };
  s.dem.criterion = study::TimeStepCriterion::Rayleigh;
  // Rayleigh: pi R sqrt(rho/G) / (0.1631 nu + 0.8766) at R = 4.75 mm, G = E / 2.6 (docs/architecture.md section 11)
  const double rayleigh = std::numbers::pi * 0.00475 * std::sqrt(2600 / (5e6 / 2.6)) / (0.1631 * 0.3 + 0.8766);
  CHECK(deckStep(s) == Approx(study::demStepDividing(0.2 * rayleigh, s.fem.dt_s)).epsilon(1e-12));
  s.dem.criterion = study::TimeStepCriterion::StiffestSpring;
  // LIGGGHTS hooke against the steel wall: Y* = 1 / ((1 - 0.09)/5e6 + (1 - 0.09)/2e8), R* = R, m* = m, V = 0.5
  const double y_eff = 1 / (0.91 / 5e6 + 0.91 / 2e8);
  const double mass = 2600 * 4.0 / 3.0 * std::numbers::pi * std::pow(0.00475, 3);
  const double kn = 16.0 / 15.0 * std::sqrt(0.00475) * y_eff *
                    std::pow(15.0 * mass * 0.25 / (16.0 * std::sqrt(0.00475) * y_eff), 0.2);
  CHECK(deckStep(s) == Approx(study::demStepDividing(0.2 * std::numbers::pi * std::sqrt(mass / kn), s.fem.dt_s)).epsilon(1e-12));
  s.dem.dt_s = 2.5e-6;
  CHECK(deckStep(s) == Approx(2.5e-6).epsilon(1e-12));
}

TEST_CASE("the tool STL holds the keypoint triangles at the start position, outward normals", "[liggghts]") {
  const auto s = smallStudy();
  const auto surface = liggghts::toolSurface(s, 0);
  const auto origin = liggghts::toolStartOrigin(s, 0);
  CHECK(origin[0] == Approx(0.04));            // centred across the 80 mm bin
  CHECK(origin[1] == Approx(0.0505));          // tip one largest diameter above the 40 mm surface
  CHECK(origin[2] == Approx(-0.0015));         // front face at start_z = 0
  const auto file = std::filesystem::temp_directory_path() / "demfem-liggghts-test-tool.stl";
  liggghts::writeToolStl(surface, origin, file);
  std::ifstream in(file);
  std::string word;
  std::size_t facets = 0, vertices = 0;
  double max_z = -1;
  while (in >> word) {
    if (word == "facet") ++facets;
    if (word == "vertex") {
      double x, y, z;
      in >> x >> y >> z;
      ++vertices;
      max_z = std::max(max_z, z);
    }
  }
  std::filesystem::remove(file);
  CHECK(facets == surface.triangles.size());
  CHECK(vertices == 3 * surface.triangles.size());
  CHECK(max_z == Approx(0.0).margin(1e-12));  // front face at z = 0
}

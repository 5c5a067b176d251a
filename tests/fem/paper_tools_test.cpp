// The Section 2.9 tools (PMMA 200x40x4 mm, S235 200x40x3 mm, Table 3) at full size: keypoint
// reduction against the full model, and against CalculiX (Debian calculix-ccx): same mesh, element
// (C3D20R for the reduced 2x2x2 rule, C3D20 for the full rule), material and constraints. The test
// writes the deck, runs ccx and parses its .dat output. Slow (several dense reductions): `physics`.
#include "fem_test_tools.hpp"

#include "demfem/fem/model.hpp"
#include "demfem/fem/sensors.hpp"

#include <catch2/catch.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

using namespace demfem;
using namespace demfem::fem;

namespace {

struct CalculixResult {
  std::vector<double> frequencies_Hz;
  double load_cell_reaction_z_N = 0;
};

std::vector<int> tipNodes(const FullModel& model) {
  std::vector<int> nodes;
  for (std::size_t k = 0; k < model.keypoint_nodes.size(); ++k)
    if (std::abs(model.keypoints(static_cast<Eigen::Index>(k), 1)) < 1e-12) nodes.push_back(model.keypoint_nodes[k]);
  return nodes;
}

void writeNodeSet(std::ostream& out, const std::string& name, const std::vector<int>& nodes) {
  out << "*NSET, NSET=" << name << "\n";
  for (std::size_t i = 0; i < nodes.size(); ++i) out << nodes[i] + 1 << ((i % 10 == 9 || i + 1 == nodes.size()) ? "\n" : ", ");
}

// Frequency step (first `modes` modes) and a static step with `tip_load_N` along -z on the tip nodes.
CalculixResult runCalculix(const FullModel& model, const study::Tool& tool, HexIntegration integration, int modes,
                           double tip_load_N) {
  const auto dir = std::filesystem::temp_directory_path() / ("demfem_ccx_" + tool.name + (integration == HexIntegration::Reduced ? "_r" : "_f"));
  std::filesystem::create_directories(dir);
  {
    std::ofstream deck(dir / "tool.inp");
    deck.precision(17);
    deck << "*HEADING\ndemfem FEM comparison: " << tool.name << "\n*NODE, NSET=NALL\n";
    for (std::size_t n = 0; n < model.mesh.nodes.size(); ++n)
      deck << n + 1 << ", " << model.mesh.nodes[n].x() << ", " << model.mesh.nodes[n].y() << ", " << model.mesh.nodes[n].z() << "\n";
    deck << "*ELEMENT, TYPE=" << (integration == HexIntegration::Reduced ? "C3D20R" : "C3D20") << ", ELSET=EALL\n";
    for (std::size_t e = 0; e < model.mesh.elements.size(); ++e) {
      const auto& nodes = model.mesh.elements[e].nodes;
      // At most 16 entries per line: element number and 15 nodes, the rest on a continuation line.
      deck << e + 1;
      for (std::size_t a = 0; a < nodes.size(); ++a) deck << (a == 15 ? ",\n" : ", ") << nodes[a] + 1;
      deck << "\n";
    }
    std::vector<int> clamp, load_cell;
    for (std::size_t i = 0; i < model.constraints.fixed_dofs.size(); ++i) {
      const int dof = model.constraints.fixed_dofs[i];
      if (dof % 3 == 0 && i + 2 < model.constraints.fixed_dofs.size() && model.constraints.fixed_dofs[i + 2] == dof + 2) clamp.push_back(dof / 3);
    }
    for (int dof : model.constraints.load_cell_dofs) load_cell.push_back(dof / 3);
    const std::vector<int> tip = tipNodes(model);
    writeNodeSet(deck, "CLAMP", clamp);
    writeNodeSet(deck, "LOADCELL", load_cell);
    deck << "*BOUNDARY\nCLAMP, 1, 3\nLOADCELL, 3, 3\n";
    deck << "*MATERIAL, NAME=TOOL\n*ELASTIC\n" << tool.fem.youngs_Pa << ", " << tool.fem.poisson << "\n*DENSITY\n"
         << tool.fem.density_kg_m3 << "\n*SOLID SECTION, ELSET=EALL, MATERIAL=TOOL\n";
    deck << "*STEP\n*FREQUENCY\n" << modes << "\n*END STEP\n";
    deck << "*STEP\n*STATIC\n*CLOAD\n";
    for (int n : tip) deck << n + 1 << ", 3, " << -tip_load_N / static_cast<double>(tip.size()) << "\n";
    deck << "*NODE PRINT, NSET=LOADCELL, TOTALS=ONLY\nRF\n*END STEP\n";
  }
  const std::string command = "cd '" + dir.string() + "' && OMP_NUM_THREADS=1 ccx -i tool > ccx.log 2>&1";
  REQUIRE(std::system(command.c_str()) == 0);
  std::ifstream dat(dir / "tool.dat");
  REQUIRE(dat.good());
  CalculixResult result;
  std::string line;
  bool in_eigen = false, next_is_total = false;
  while (std::getline(dat, line)) {
    if (line.find("E I G E N V A L U E   O U T P U T") != std::string::npos) {
      in_eigen = true;
      continue;
    }
    if (line.find("total force") != std::string::npos) {
      next_is_total = true;
      in_eigen = false;
      continue;
    }
    std::istringstream s(line);
    if (next_is_total) {
      double fx = 0, fy = 0, fz = 0;
      if (s >> fx >> fy >> fz) {
        result.load_cell_reaction_z_N = fz;
        next_is_total = false;
      }
      continue;
    }
    if (in_eigen) {
      int mode = 0;
      double eigenvalue = 0, rad = 0, cycles = 0;
      if (s >> mode >> eigenvalue >> rad >> cycles && mode == static_cast<int>(result.frequencies_Hz.size()) + 1)
        result.frequencies_Hz.push_back(cycles);
      else if (!result.frequencies_Hz.empty() && static_cast<int>(result.frequencies_Hz.size()) >= modes)
        in_eigen = false;
    }
  }
  return result;
}

void compareWithCalculix(const study::Tool& tool, HexIntegration integration) {
  const FullModel full = buildPlateModel(tool, integration);
  const CalculixResult ccx = runCalculix(full, tool, integration, 3, 1.0);
  REQUIRE(ccx.frequencies_Hz.size() == 3);
  const Modes ours = naturalModes(full, 3);
  for (int m = 0; m < 3; ++m) {
    INFO(tool.name << " mode " << m + 1 << ": demfem " << ours.frequencies_Hz[m] << " Hz, CalculiX " << ccx.frequencies_Hz[m] << " Hz");
    CHECK(ours.frequencies_Hz[m] == Approx(ccx.frequencies_Hz[m]).epsilon(0.01));  // issue 3: 1 %
  }
  // Load-cell reaction under a 1 N tip load against travel, from the reduced model's sensors.
  const ReducedModel reduced = reduce(full);
  Eigen::VectorXd f = Eigen::VectorXd::Zero(reduced.dofCount());
  const std::vector<int> tip = tipNodes(full);
  for (int k = 0; k < reduced.keypointCount(); ++k)
    if (std::abs(reduced.keypoints(k, 1)) < 1e-12) f(3 * k + 2) = -1.0 / static_cast<double>(tip.size());
  const StaticSolution s = solveStatic(reduced, f);
  const SensorReadings reading = Sensors(reduced, tool).read(s.displacement, s.reaction);
  INFO(tool.name << " load cell: demfem " << reading.load_cell_N << " N, CalculiX " << ccx.load_cell_reaction_z_N << " N");
  CHECK(reading.load_cell_N == Approx(ccx.load_cell_reaction_z_N).epsilon(0.005));  // issue 3: 0.5 %
}

}  // namespace

TEST_CASE("the PMMA tool agrees with CalculiX C3D20R on frequencies and load-cell reaction", "[fem][physics]") {
  compareWithCalculix(testing::pmmaTool(), HexIntegration::Reduced);
}

TEST_CASE("the S235 tool agrees with CalculiX C3D20R on frequencies and load-cell reaction", "[fem][physics]") {
  compareWithCalculix(testing::steelTool(), HexIntegration::Reduced);
}

TEST_CASE("the fully integrated element agrees with CalculiX C3D20 on the PMMA tool", "[fem][physics]") {
  compareWithCalculix(testing::pmmaTool(), HexIntegration::Full);
}

TEST_CASE("the reduced PMMA and S235 tools reproduce the full static response at the keypoints", "[fem][physics]") {
  testing::checkReducedStaticEqualsFull(testing::pmmaTool());
  testing::checkReducedStaticEqualsFull(testing::steelTool());
}

TEST_CASE("the reduced PMMA and S235 tools keep the first frequency within 0.5 % and never below", "[fem][physics]") {
  testing::checkReducedFrequencies(testing::pmmaTool());
  testing::checkReducedFrequencies(testing::steelTool());
}

TEST_CASE("the PMMA tool's load-cell influence coefficients split 10 N on the tip as its FEM model does, not as a hinge",
          "[fem][physics]") {
  const study::Tool tool = testing::pmmaTool();
  const ReducedModel model = reduce(buildPlateModel(tool));
  const Eigen::VectorXd c = loadCellInfluence(model);
  const Sensors sensors(model, tool.constraints.sensor_from_top_m);
  const auto staticLoadCell = [&](const Eigen::VectorXd& f) {
    const StaticSolution s = solveStatic(model, f);
    return sensors.read(s.displacement, s.reaction).load_cell_N;
  };
  // The sensors of the static solution (checked against CalculiX above) for any force pattern,
  // free and fixed DOFs alike: the coefficients are exact up to the solver's round-off.
  const Eigen::VectorXd random = Eigen::VectorXd::Random(model.dofCount());
  CHECK(c.dot(random) == Approx(staticLoadCell(random)).epsilon(1e-9));
  const Eigen::VectorXd tip = testing::tipLoad(model, 10.0);
  const double load_cell_N = c.dot(tip);
  CHECK(load_cell_N == Approx(staticLoadCell(tip)).epsilon(1e-9));
  // Against beam theory: a cantilever clamped at the clamp's edge (y_c = 160 mm) and propped at the
  // load cell a = 25 mm below it carries a tip load P at l = 160 mm with the prop reaction
  // R = P (3 l - a) / (2 a) = 9.1 P (Euler-Bernoulli). The 25 mm span is only 6 thicknesses long, so
  // shear and the 3-D clamp make the real plate softer there and the prop take less: the FEM gives
  // 87 N; 6 % covers that. The hinge lever of the lever rule, P l / a = 64 N, is far off.
  const double l = 0.160, a = 0.025;
  INFO("load cell for 10 N on the tip: " << load_cell_N << " N");
  CHECK(load_cell_N == Approx(10.0 * (3 * l - a) / (2 * a)).epsilon(0.06));
  CHECK(load_cell_N == Approx(87.0).margin(1.0));
  CHECK(load_cell_N > 1.3 * 10.0 * l / a);
}

// The cone penetrometer as the builtin DEM meshes it (adapter/tool_surface.hpp) pressed on one sphere
// resting on the floor: the force on the cone is the contact law's, K1 delta (docs/builtin-dem.md).
#include "demfem/backends/builtin/backend.hpp"
#include "demfem/backends/builtin/simulation.hpp"
#include "test_soil.hpp"
#include "support/study_in_code.hpp"

#include <catch2/catch.hpp>

#include <cmath>
#include <numbers>

using namespace demfem;
using namespace demfem::builtin;
using namespace demfem::builtin::testing;

TEST_CASE("a cone pressed on a single resting sphere gets the contact law's force K1 delta", "[builtin]") {
  SoilParameters p;
  p.model.damping_factor = 0;  // at rest: no viscous term either way
  const double radius = 0.005, delta = 1e-5;
  study::Tool tool;
  tool.name = "cone";
  support::usePaperCone(tool, 0.05);
  TriangleMesh mesh = toolMesh(tool);
  mesh.material = 1;

  DemSimulation sim(makeSoil(p), box(0.1), 1);
  sim.setGravity({0, 0, 0});
  sim.addPlane({{0, 0, 0}, {0, 1, 0}, 1});  // the floor the sphere rests on (touching, no overlap)
  sim.addParticle({{0.01, radius, -0.02}, {0, 0, 0}, {0, 0, 0}, radius, 0, 0});
  const int m = sim.addMesh(mesh);
  sim.setMeshMotion(m, {0.01, 2 * radius - delta, -0.02}, {0, 0, 0}, 0);  // tip delta into the sphere's top
  sim.setTimeStep(1e-7);
  sim.run(1);

  // Walton-Braun loading branch against a wall: K1 = 5 R* Y with R* = R.
  const double expected = 5 * radius * p.yield * delta;
  Vec3 total{0, 0, 0};
  const auto& f = sim.nodeForces(m);
  for (std::size_t k = 0; k < f.size() / 3; ++k)
    for (int c = 0; c < 3; ++c) total[c] += f[3 * k + c];
  CHECK(total[1] == Approx(expected).epsilon(1e-6));  // upwards on the cone, from the sphere below
  CHECK(std::fabs(total[0]) < 1e-9 * expected);
  CHECK(std::fabs(total[2]) < 1e-9 * expected);
  CHECK(f[1] == Approx(expected).epsilon(1e-6));      // all of it on the tip node 0
  // The floor (touching at zero overlap, no force yet) and the tip vertex once, not once per triangle.
  CHECK(sim.contactCount() == 2);
  CHECK(std::fabs(sim.planeForce(0)[1]) < 1e-6 * expected);
}

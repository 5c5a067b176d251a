// Soil-motion measures on synthetic particle fields whose answers are known exactly.
#include "demfem/analysis/recording.hpp"
#include "demfem/analysis/soil_motion.hpp"
#include "demfem/analysis/soil_motion_report.hpp"
#include "demfem/vtkio/vtk_files.hpp"
#include "support/temp_dir.hpp"

#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>

using namespace demfem::analysis;

namespace {

constexpr double kD = 0.01;  // lattice spacing = particle diameter

// A simple cubic lattice of nx x ny x nz spheres of radius 5 mm, centres at (i + 0.5) kD; layer by
// height: `layers` equal slabs from the top (0 = top).
ParticleFrame lattice(int nx, int ny, int nz, int layers) {
  ParticleFrame f;
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        f.position_m.insert(f.position_m.end(), {(i + 0.5) * kD, (j + 0.5) * kD, (k + 0.5) * kD});
        f.velocity_m_s.insert(f.velocity_m_s.end(), {0.0, 0.0, 0.0});
        f.radius_m.push_back(kD / 2);
        f.layer.push_back((ny - 1 - j) * layers / ny);
      }
  return f;
}

}  // namespace

TEST_CASE("the extent of a synthetic field with a known moving box is exact", "[analysis]") {
  ParticleFrame f = lattice(20, 8, 40, 1);
  // Particles with centres in x 65..125 mm, y 25..75 mm, z 105..245 mm (7 x 6 x 15) move at 30 mm/s
  // along z; the rest creep at 1 mm/s. Sphere bounds: x 60..130, y 20..80, z 100..250 mm.
  for (std::size_t i = 0; i < f.size(); ++i) {
    const double* p = &f.position_m[3 * i];
    const bool inside = p[0] > 0.059 && p[0] < 0.131 && p[1] > 0.024 && p[1] < 0.076 && p[2] > 0.104 && p[2] < 0.246;
    f.velocity_m_s[3 * i + 2] = inside ? 0.030 : 0.001;
  }
  const auto e = movingExtent(f, 0.010, 0.080);
  CHECK(e.count == 7u * 6 * 15);
  CHECK(e.depth_m == Approx(0.060).epsilon(1e-12));   // surface 80 mm, lowest point 20 mm
  CHECK(e.length_m == Approx(0.150).epsilon(1e-12));
  CHECK(e.width_m == Approx(0.070).epsilon(1e-12));
  CHECK(movingExtent(f, 0.05, 0.08).count == 0);

  // In front of the box's front face (z 245 mm), within one diameter: nothing moves fast.
  const auto front = frontVelocityRange(f, Box{{0.06, 0.02, 0.25}, {0.13, 0.08, 0.26}});
  CHECK(front.count == 7u * 6);
  CHECK(front.max_m_s == Approx(0.001));
  const auto inside = frontVelocityRange(f, Box{{0.06, 0.02, 0.23}, {0.13, 0.08, 0.246}});
  CHECK(inside.min_m_s == Approx(0.030));
}

TEST_CASE("the region in motion connected to the tool leaves out fast particles that do not touch it", "[analysis]") {
  ParticleFrame f = lattice(20, 8, 40, 1);
  // The moving box of the case above (centres x 65..125, y 25..75, z 105..245 mm) at 30 mm/s, and two
  // lone fast particles: one at (5, 75, 395) mm, far from it, and one at (145, 55, 165) mm, one empty
  // lattice site (a 10 mm surface gap) beyond the box's side.
  const auto at = [&](double x, double y, double z) {
    for (std::size_t i = 0; i < f.size(); ++i)
      if (std::fabs(f.position_m[3 * i] - x) < 1e-9 && std::fabs(f.position_m[3 * i + 1] - y) < 1e-9 && std::fabs(f.position_m[3 * i + 2] - z) < 1e-9)
        return i;
    FAIL("no lattice site there");
    return std::size_t{0};
  };
  for (std::size_t i = 0; i < f.size(); ++i) {
    const double* p = &f.position_m[3 * i];
    const bool inside = p[0] > 0.059 && p[0] < 0.131 && p[1] > 0.024 && p[1] < 0.076 && p[2] > 0.104 && p[2] < 0.246;
    f.velocity_m_s[3 * i + 2] = inside ? 0.030 : 0.001;
  }
  f.velocity_m_s[3 * at(0.005, 0.075, 0.395) + 2] = 0.030;
  f.velocity_m_s[3 * at(0.145, 0.055, 0.165) + 2] = 0.030;
  const Box tool{{0.08, 0.05, 0.245}, {0.11, 0.12, 0.255}};  // its front face against the box's at z 245-250 mm
  Box seed = tool;
  for (int c = 0; c < 3; ++c) seed.lo[c] -= 0.0105, seed.hi[c] += 0.0105;

  const auto all = movingExtent(f, 0.010, 0.080);
  CHECK(all.count == 7u * 6 * 15 + 2);
  CHECK(all.length_m == Approx(0.300).epsilon(1e-12));  // z 100..400 mm: out to the lone particle at 395 mm
  const auto connected = connectedMovingExtent(f, 0.010, 0.080, seed, 0.001);
  CHECK(connected.count == 7u * 6 * 15);  // the box alone: the particle 10 mm beyond its side is not linked
  CHECK(connected.depth_m == Approx(0.060).epsilon(1e-12));
  CHECK(connected.length_m == Approx(0.150).epsilon(1e-12));
  CHECK(connected.width_m == Approx(0.070).epsilon(1e-12));
  // A gap of 10 mm links the near particle (the far one stays out); nothing fast near the tool: none.
  CHECK(connectedMovingExtent(f, 0.010, 0.080, seed, 0.0101).count == 7u * 6 * 15 + 1);
  const Box elsewhere{{0.0, 0.0, 0.30}, {0.05, 0.05, 0.35}};
  CHECK(connectedMovingExtent(f, 0.010, 0.080, elsewhere, 0.001).count == 0);
}

TEST_CASE("a vertical velocity section bins the mean speed of the particles on the plane", "[analysis]") {
  ParticleFrame f = lattice(4, 3, 5, 1);
  for (std::size_t i = 0; i < f.size(); ++i) f.velocity_m_s[3 * i] = f.position_m[3 * i + 2];  // |v| = z (per s)
  const auto map = velocitySection(f, Axis::X, 0.025, 0.006, 0.02);  // the plane x = 25 mm holds one column of centres
  CHECK(map.nu == 3);   // z centres 5 to 45 mm in cells [5, 25), [25, 45), [45, 65) mm
  CHECK(map.nv == 2);   // y centres 5 to 25 mm
  CHECK(map.at(0, 0) == Approx(0.010));  // z 5 and 15 mm
  CHECK(map.at(1, 1) == Approx(0.030));  // z 25 and 35 mm, y 25 mm
  CHECK(map.at(2, 0) == Approx(0.045));
  const auto horizontal = velocitySection(f, Axis::Y, 0.015, 0.004, 0.02);  // the middle row
  CHECK(horizontal.nv == 2);  // x centres 5 to 35 mm
  CHECK(horizontal.at(2, 1) == Approx(0.045));
}

TEST_CASE("mixing is 0 for untouched layers and reaches its maximum for a random permutation", "[analysis]") {
  ParticleFrame f = lattice(20, 12, 20, 4);  // 4 slabs of 3 particle rows
  const auto boundaries = layerBoundaries(f);
  REQUIRE(boundaries.size() == 3);
  CHECK(boundaries[0] == Approx(0.09));  // between the rows at 85 and 95 mm
  CHECK(mixingIndex(f, 0.04, boundaries) == 0.0);

  // Labels (ix + iy) mod 4: every 2 x 12 x 2 column holds each label 12 times, the global proportions -> 1.
  ParticleFrame dealt = f;
  for (std::size_t i = 0; i < dealt.size(); ++i)
    dealt.layer[i] = static_cast<int>(std::lround(dealt.position_m[3 * i] / kD - 0.5) + std::lround(dealt.position_m[3 * i + 1] / kD - 0.5)) % 4;
  CHECK(mixingIndex(dealt, 0.02, {}) == Approx(1.0).epsilon(1e-12));

  ParticleFrame shuffled = f;
  std::mt19937 rng(7);
  std::shuffle(shuffled.layer.begin(), shuffled.layer.end(), rng);
  const double random = mixingIndex(shuffled, 0.04, boundaries);
  CHECK(random > 0.9);  // 4800 particles, about 50 per cell: the finite-sample entropy deficit is a few %
  CHECK(random <= 1.0);
}

namespace {

// A lattice of nx x ny x nz particles on a section through its middle x column (cells of 2 spacings:
// 4 particles per cell on the plane x = 5 mm) moving with velocity(z, y) = (v_z, v_y).
template <class Velocity>
FlowSection latticeFlow(int ny, int nz, Velocity&& velocity, double threshold_m_s = 0.005) {
  ParticleFrame f = lattice(1, ny, nz, 1);
  for (std::size_t i = 0; i < f.size(); ++i) {
    const auto [vz, vy] = velocity(f.position_m[3 * i + 2], f.position_m[3 * i + 1]);
    f.velocity_m_s[3 * i + 1] = vy;
    f.velocity_m_s[3 * i + 2] = vz;
  }
  return flowSection(f, Axis::X, 0.005, 0.006, 2 * kD, threshold_m_s);
}

}  // namespace

TEST_CASE("a uniform flow is fully ordered and its streamlines span the region along the flow", "[analysis]") {
  const auto flow = latticeFlow(6, 20, [](double, double) { return std::pair{0.03, 0.0}; });  // 10 x 3 cells, 200 x 60 mm
  const auto order = alignmentOrder(flow);
  CHECK(order.cells == 30u);
  CHECK(order.particles == 120u);
  CHECK(order.order == Approx(1.0).epsilon(1e-12));
  CHECK(order.random_baseline == Approx(0.5).epsilon(1e-12));  // 1/sqrt(4)

  const auto lines = traceStreamlines(flow, StreamlineRules{});
  REQUIRE(lines.size() == 30u);
  // Cell-centre seeds from z = 5 mm (the lowest centre): the region spans z 5 to 205 mm, 200 mm.
  for (const auto& l : lines) {
    CHECK(l.length_m == Approx(0.200).margin(1e-9));
    CHECK(l.turning_rad == Approx(0).margin(1e-12));
    CHECK(l.u_m.front() == Approx(0.005).margin(1e-9));
  }
  const auto s = streamlineStatistics(lines);
  CHECK(s.count == 30u);
  CHECK(s.mean_length_m == Approx(0.200).margin(1e-9));
  CHECK(s.median_length_m == Approx(0.200).margin(1e-9));
  CHECK(s.curvature_rad_per_m == Approx(0).margin(1e-9));

  // Along the diagonal of a 200 x 60 mm region the line through a centre ends on its edges.
  const auto diagonal = latticeFlow(6, 20, [](double, double) { return std::pair{0.03, 0.03}; });
  for (const auto& l : traceStreamlines(diagonal, StreamlineRules{}))
    CHECK(l.length_m <= std::sqrt(2.0) * 0.060 + 1e-9);
}

TEST_CASE("streamlines of a rigid rotation are circles of their seed radius with curvature 1/r", "[analysis]") {
  // omega = 1 rad/s about the cell centre (z, y) = (215, 215) mm of a 400 x 400 mm lattice (cells of
  // 20 mm from the lowest centre at 5 mm): v = omega x r. A cell's particles sit at its centre minus
  // half a spacing (centres 5 and 15 mm in the cell 5-25 mm), so the field is given at the particle
  // plus half a spacing: the cell means are then the rotation at the cell centres.
  constexpr double c = 0.215, half = kD / 2;
  const auto flow = latticeFlow(40, 40, [](double z, double y) { return std::pair{-(y + half - c), z + half - c}; });
  const StreamlineRules rules;  // step 5 mm, one full turn at most
  const auto lines = traceStreamlines(flow, rules);
  // The cell centre (155, 215) mm sits at r = 60 mm: its line closes on itself after one turn.
  const auto line = std::find_if(lines.begin(), lines.end(), [](const Streamline& l) {
    return std::fabs(l.seed_u_m - 0.155) < 1e-9 && std::fabs(l.seed_v_m - 0.215) < 1e-9;
  });
  REQUIRE(line != lines.end());
  const double r = 0.060, h = rules.step_fraction * 0.02;
  // Bounded by the one-turn rule: n steps turn n - 1 times by h / r, so within one step of 2 pi r.
  CHECK(line->length_m == Approx(2 * M_PI * r).margin(h));
  CHECK(line->turning_rad <= 2 * M_PI + 1e-12);
  CHECK(line->turning_rad > 2 * M_PI - 1.01 * h / r);
  for (std::size_t k = 0; k < line->u_m.size(); ++k)      // the midpoint rule drifts by O(h^2 / r) per turn
    CHECK(std::hypot(line->u_m[k] - c, line->v_m[k] - c) == Approx(r).epsilon(0.005));
  CHECK(line->turning_rad / line->length_m == Approx(1 / r).epsilon(0.02));

  // A tighter turn than the per-step rule allows: steps of a whole cell (20 mm) at r = 20 mm turn by
  // h / r = 1 rad > 30 degrees, so the lines there end at their first turn, after one step.
  StreamlineRules coarse;
  coarse.step_fraction = 1;
  const auto coarse_lines = traceStreamlines(flow, coarse);
  const auto near = std::find_if(coarse_lines.begin(), coarse_lines.end(), [](const Streamline& l) {
    return std::fabs(l.seed_u_m - 0.195) < 1e-9 && std::fabs(l.seed_v_m - 0.215) < 1e-9;
  });
  REQUIRE(near != coarse_lines.end());
  CHECK(near->length_m == Approx(0.02).margin(1e-12));
  CHECK(near->turning_rad == 0.0);
}

TEST_CASE("random directions give an alignment order near 1/sqrt(n)", "[analysis]") {
  // 8 moving particles per cell (two x columns, 2 x 2 per column), 25 x 20 cells, 3-D directions
  // uniform on the sphere at 20 mm/s. For large n the mean |mean unit vector| is sqrt(8 / (3 pi n))
  // = 0.921 / sqrt(n) (Maxwell distribution of a 3-D random walk; its rms is exactly 1/sqrt(n)); the
  // 500-cell mean scatters by about 0.02 / sqrt(n): the band 0.85 - 0.99 / sqrt(n) is > 3 sigma wide.
  ParticleFrame f = lattice(2, 40, 50, 1);
  std::mt19937 rng(11);
  std::normal_distribution<double> gauss;
  for (std::size_t i = 0; i < f.size(); ++i) {
    const double x = gauss(rng), y = gauss(rng), z = gauss(rng), n = std::sqrt(x * x + y * y + z * z);
    for (int c = 0; c < 3; ++c) f.velocity_m_s[3 * i + c] = 0.02 * std::array{x, y, z}[c] / n;
  }
  const auto order = alignmentOrder(flowSection(f, Axis::X, 0.010, 0.006, 2 * kD, 0.005));
  REQUIRE(order.cells == 500u);
  CHECK(order.particles == 4000u);
  CHECK(order.random_baseline == Approx(1 / std::sqrt(8.0)).epsilon(1e-12));
  CHECK(order.order > 0.85 / std::sqrt(8.0));
  CHECK(order.order < 0.99 / std::sqrt(8.0));
}

TEST_CASE("a flow below the threshold has no streamlines and no order, reported as none", "[analysis]") {
  const auto flow = latticeFlow(6, 20, [](double, double) { return std::pair{0.003, 0.0}; });  // 3 mm/s < 5 mm/s
  CHECK(alignmentOrder(flow).cells == 0u);
  CHECK(std::isnan(alignmentOrder(flow).order));
  const auto lines = traceStreamlines(flow, StreamlineRules{});
  CHECK(lines.empty());
  const auto s = streamlineStatistics(lines);
  CHECK(s.count == 0u);
  CHECK(std::isnan(s.mean_length_m));
  CHECK(std::isnan(s.median_length_m));
  CHECK(std::isnan(s.curvature_rad_per_m));
}

TEST_CASE("flow sections and streamlines refuse an empty frame, a cell <= 0 and bad tracing rules", "[analysis]") {
  const ParticleFrame empty;
  CHECK_THROWS_WITH(flowSection(empty, Axis::X, 0, 0.005, 0.01, 0.005), Catch::Contains("no particles"));
  const ParticleFrame f = lattice(2, 2, 2, 1);
  CHECK_THROWS_WITH(flowSection(f, Axis::X, 0, 0.005, 0.0, 0.005), Catch::Contains("cell size must be > 0"));
  CHECK_THROWS_WITH(flowSection(f, Axis::X, 0, 0.005, -0.01, 0.005), Catch::Contains("cell size must be > 0"));
  CHECK_THROWS_WITH(flowSection(f, Axis::X, 0, 0.005, 0.01, -1), Catch::Contains("threshold"));
  const auto flow = flowSection(f, Axis::X, 0.005, 0.006, 0.01, 0.005);
  StreamlineRules zero_step;
  zero_step.step_fraction = 0;
  CHECK_THROWS_WITH(traceStreamlines(flow, zero_step), Catch::Contains("step fraction"));
  StreamlineRules no_turn;
  no_turn.max_step_turn_rad = 0;
  CHECK_THROWS_WITH(traceStreamlines(flow, no_turn), Catch::Contains("turning limits"));
}

TEST_CASE("the soil-motion JSON reports a still section's streamline order and lengths as null, not zero", "[analysis]") {
  SoilMotionRun still;
  still.name = "still";
  SoilMotionInstant in;
  in.flow = latticeFlow(6, 20, [](double, double) { return std::pair{0.003, 0.0}; });
  in.order = alignmentOrder(in.flow);
  in.streamlines = traceStreamlines(in.flow, StreamlineRules{});
  in.streamline_statistics = streamlineStatistics(in.streamlines);
  still.instants.push_back(in);
  const SoilMotionSettings settings;
  const auto doc = soilMotionJson({still}, settings);
  const auto& j = doc["runs"][0]["instants"][0];
  CHECK(j["streamlines"] == 0);
  CHECK(j["streamline_order_cells"] == 0);
  for (const char* key : {"streamline_order", "streamline_order_random_baseline", "mean_streamline_length_mm", "median_streamline_length_mm",
                          "streamline_curvature_rad_per_mm"})
    CHECK(j[key].is_null());
  CHECK(doc["streamline_step_mm"].get<double>() == Approx(5.0));
  CHECK(soilMotionMarkdown({still}, settings).find("none (nothing in motion)") != std::string::npos);
}

TEST_CASE("a run marked incomplete by its sensors.json is refused naming the file", "[analysis]") {
  const demfem::support::TempDir dir("soil-motion-incomplete");
  std::ofstream(dir / "sensors.json") << R"({"complete": false, "incomplete_reason": "DEM blew up"})";
  CHECK_THROWS_WITH(loadRun(dir.path()), Catch::Contains("sensors.json: /complete: the run is marked incomplete") && Catch::Contains("DEM blew up"));
  std::ofstream(dir / "sensors.json") << R"({"complete": true})";
  CHECK_THROWS_WITH(loadRun(dir.path()), Catch::Contains("particles.pvd"));  // complete: on to the particle files, absent here
}

TEST_CASE("against the bed's rest state a creeping floor layer is not motion and the region stops above it", "[analysis]") {
  // The moving box of the cases above (centres x 65..125, y 25..75, z 105..245 mm) at 30 mm/s, on a
  // floor layer (the two lowest rows, centres y 5 and 15 mm) that creeps at 6 mm/s along z, faster
  // than the 5 mm/s threshold, in the run and in the rest run alike: the bed's own creep.
  ParticleFrame run = lattice(20, 8, 40, 1);
  ParticleFrame rest = run;
  for (std::size_t i = 0; i < run.size(); ++i) {
    const double* p = &run.position_m[3 * i];
    const bool box = p[0] > 0.059 && p[0] < 0.131 && p[1] > 0.024 && p[1] < 0.076 && p[2] > 0.104 && p[2] < 0.246;
    const bool floor = p[1] < 0.02;
    run.velocity_m_s[3 * i + 2] = box ? 0.030 : floor ? 0.006 : 0.0;
    rest.velocity_m_s[3 * i + 2] = floor ? 0.006 : 0.0;
    rest.velocity_m_s[3 * i] = floor ? 1e-4 : 0.0;  // and the rest run's own x-creep, which the run lacks: 0.1 mm/s
  }
  Box seed{{0.08, 0.05, 0.245}, {0.11, 0.12, 0.255}};
  for (int c = 0; c < 3; ++c) seed.lo[c] -= 0.0105, seed.hi[c] += 0.0105;
  // As the velocities are, the box and the floor below it are one region: 80 mm deep, down to the floor.
  const auto raw = connectedMovingExtent(run, 0.005, 0.080, seed, 0.001);
  CHECK(raw.depth_m == Approx(0.080).epsilon(1e-12));
  CHECK(raw.count == 7u * 6 * 15 + 2 * 20 * 40);
  // Against the rest state: the box alone, 60 mm deep (its lowest point at y = 20 mm).
  const ParticleFrame moved = againstRest(run, rest, "rest.vtp");
  const auto region = connectedMovingExtent(moved, 0.005, 0.080, seed, 0.001);
  CHECK(region.count == 7u * 6 * 15);
  CHECK(region.depth_m == Approx(0.060).epsilon(1e-12));
  CHECK(moved.speed(0) == Approx(1e-4).epsilon(1e-9));  // a floor particle: what differs from its rest (the x-creep)
  // A floor that moves in the run beyond its rest (the tool really reaching it) is still motion.
  for (std::size_t i = 0; i < run.size(); ++i)
    if (run.position_m[3 * i + 1] < 0.02) run.velocity_m_s[3 * i + 2] = 0.012;
  CHECK(connectedMovingExtent(againstRest(run, rest, "rest.vtp"), 0.005, 0.080, seed, 0.001).depth_m == Approx(0.080).epsilon(1e-12));
}

TEST_CASE("a rest run is found by time and refused when it is not the same bed", "[analysis]") {
  const demfem::support::TempDir dir("soil-motion-rest");
  std::filesystem::create_directories(dir / "vtk");
  ParticleFrame f = lattice(2, 2, 2, 1);
  demfem::vtkio::Dataset d;
  d.time_s = 0.25;
  d.points = f.position_m;
  d.arrays = {{"radius_m", 1, f.radius_m, demfem::vtkio::ValueType::Float64},
              {"velocity_m_s", 3, std::vector<double>(3 * f.size(), 0.002), demfem::vtkio::ValueType::Float64},
              {"layer", 1, std::vector<double>(f.size(), 0.0), demfem::vtkio::ValueType::Int32}};
  std::ofstream(dir / "vtk" / "particles_000010.vtp") << demfem::vtkio::encode(d, demfem::vtkio::Format::PolyData);
  std::ofstream(dir / "vtk" / "particles.pvd")
      << R"(<?xml version="1.0"?><VTKFile type="Collection" version="0.1"><Collection>)"
      << R"(<DataSet timestep="0.25" part="0" file="particles_000010.vtp"/></Collection></VTKFile>)";
  const auto file = restFrameAt(dir.path(), 0.25 + 5e-7);
  CHECK(file.filename() == "particles_000010.vtp");
  CHECK_THROWS_WITH(restFrameAt(dir.path(), 0.26), Catch::Contains("particles.pvd: no particle file at t = 0.26"));
  const ParticleFrame rest = readParticleFrame(file);
  for (std::size_t i = 0; i < 3 * f.size(); ++i) f.velocity_m_s[i] = 0.005;
  const ParticleFrame moved = againstRest(f, rest, file);
  CHECK(moved.speed(3) == Approx(std::sqrt(3.0) * 0.003).epsilon(1e-12));
  ParticleFrame other = f;
  other.radius_m[5] = 0.0049;
  CHECK_THROWS_WITH(againstRest(other, rest, file), Catch::Contains("particles_000010.vtp: particle 5 has radius") &&
                                                        Catch::Contains("not the same bed"));
  other = lattice(2, 2, 3, 1);
  CHECK_THROWS_WITH(againstRest(other, rest, file), Catch::Contains("the rest run has 8 particles, the run 12"));
}

// The ParaView files: what encode() writes, VTK's own XML readers read back with the declared arrays,
// sizes and time; .pvd collections written by adapter::VtkSeries list the simulated times.
#include "demfem/adapter/output_files.hpp"
#include "demfem/vtkio/vtk_files.hpp"

#include <catch2/catch.hpp>

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>

namespace fs = std::filesystem;
using namespace demfem;

namespace {

fs::path freshDir(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() / ("demfem-vtkio-" + name + "-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

vtkio::Dataset particles(std::size_t n, double time_s) {
  vtkio::Dataset d;
  d.time_s = time_s;
  vtkio::PointArray radius{"radius_m", 1, {}, vtkio::ValueType::Float64};
  vtkio::PointArray velocity{"velocity_m_s", 3, {}, vtkio::ValueType::Float64};
  vtkio::PointArray layer{"layer", 1, {}, vtkio::ValueType::Int32};
  for (std::size_t i = 0; i < n; ++i) {
    const double s = static_cast<double>(i);
    d.points.insert(d.points.end(), {0.01 * s, 0.02 + 1e-3 * s, 0.3 - 1e-4 * s});
    radius.values.push_back(0.005 + 1e-6 * s);
    velocity.values.insert(velocity.values.end(), {s, -2 * s, 1.0 / (1 + s)});
    layer.values.push_back(static_cast<double>(i % 4));
  }
  d.arrays = {radius, velocity, layer};
  return d;
}

void writeText(const fs::path& file, const std::string& text) {
  std::ofstream out(file, std::ios::binary);
  out << text;
  REQUIRE(out.good());
}

}  // namespace

TEST_CASE("particles written as compressed binary .vtp are read back by VTK with their arrays and time", "[vtkio]") {
  const fs::path dir = freshDir("particles");
  const auto data = particles(257, 0.123456789012345);
  const std::string bytes = vtkio::encode(data, vtkio::Format::PolyData);
  CHECK(bytes.find("compressor=\"vtkZLibDataCompressor\"") != std::string::npos);
  CHECK(bytes.find("format=\"appended\"") != std::string::npos);
  CHECK(bytes.find("encoding=\"raw\"") != std::string::npos);
  writeText(dir / "p.vtp", bytes);

  const auto back = vtkio::read(dir / "p.vtp");
  CHECK(back.time_s == data.time_s);
  REQUIRE(back.pointCount() == 257);
  CHECK(back.points == data.points);
  CHECK(back.triangles.empty());
  REQUIRE(back.arrays.size() == 3);
  for (const auto& a : data.arrays) {
    const auto& b = back.array(a.name);
    CHECK(b.components == a.components);
    CHECK(b.type == a.type);
    CHECK(b.values == a.values);
  }
  fs::remove_all(dir);
}

TEST_CASE("a tool surface as .vtu keeps its triangles, displacement and node force", "[vtkio]") {
  const fs::path dir = freshDir("surface");
  vtkio::Dataset d;
  d.time_s = 2.5e-3;
  d.points = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
  d.triangles = {{0, 2, 1}, {0, 1, 3}, {0, 3, 2}, {1, 2, 3}};
  d.arrays = {{"displacement_m", 3, std::vector<double>(12, 1e-4), vtkio::ValueType::Float64},
              {"force_N", 3, {1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12}, vtkio::ValueType::Float64}};
  writeText(dir / "tool.vtu", vtkio::encode(d, vtkio::Format::UnstructuredGrid));
  const auto back = vtkio::read(dir / "tool.vtu");
  CHECK(back.time_s == d.time_s);
  CHECK(back.points == d.points);
  CHECK(back.triangles == d.triangles);
  CHECK(back.array("force_N").values == d.arrays[1].values);
  CHECK(back.array("displacement_m").components == 3);
  CHECK_THROWS_WITH(back.array("velocity_m_s"), Catch::Contains("has: displacement_m, force_N"));
  fs::remove_all(dir);
}

TEST_CASE("the .pvd collection carries the simulated times of its files", "[vtkio]") {
  const fs::path dir = freshDir("pvd");
  const double times[] = {0.0, 1e-3, 2.000000000000001e-3, 0.1 + 0.2};
  {
    adapter::VtkSeries series(dir / "particles.pvd");
    int k = 0;
    for (const double t : times) {
      const std::string name = "particles_" + std::to_string(k++) + ".vtp";
      writeText(dir / name, vtkio::encode(particles(3, t), vtkio::Format::PolyData));
      series.add(t, name);
    }
  }
  const auto entries = vtkio::readCollection(dir / "particles.pvd");
  REQUIRE(entries.size() == 4);
  for (std::size_t k = 0; k < entries.size(); ++k) {
    CHECK(entries[k].time_s == times[k]);
    CHECK(vtkio::read(entries[k].file).time_s == times[k]);  // the file's own time agrees
  }
  fs::remove_all(dir);
}

TEST_CASE("bad VTK input is refused naming the file and the problem", "[vtkio]") {
  const fs::path dir = freshDir("bad");
  CHECK_THROWS_WITH(vtkio::read(dir / "missing.vtp"), Catch::Contains("missing.vtp: no such file"));
  writeText(dir / "junk.vtp", "not xml at all");
  CHECK_THROWS_WITH(vtkio::read(dir / "junk.vtp"), Catch::Contains("junk.vtp"));
  CHECK_THROWS_WITH(vtkio::read(dir / "p.csv"), Catch::Contains("not a .vtp or .vtu file"));
  auto d = particles(4, 0);
  d.arrays[1].values.pop_back();
  CHECK_THROWS_WITH(vtkio::encode(d, vtkio::Format::PolyData), Catch::Contains("'velocity_m_s' has 11 values, expected 4 x 3"));
  writeText(dir / "list.pvd", "<VTKFile type=\"PolyData\"></VTKFile>");
  CHECK_THROWS_WITH(vtkio::readCollection(dir / "list.pvd"), Catch::Contains("not a VTK collection"));
  fs::remove_all(dir);
}

#include "demfem/backends/builtin/triangle_mesh.hpp"

#include "demfem/backends/physics/dem_formulas.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <tuple>

namespace demfem::builtin {

std::int64_t faceKey(std::int32_t triangle) { return static_cast<std::int64_t>(triangle) * 4 + 0; }
std::int64_t edgeKey(std::int32_t a, std::int32_t b) {
  const std::int64_t lo = std::min(a, b), hi = std::max(a, b);
  return ((hi << 31) + lo) * 4 + 1;
}
std::int64_t vertexKey(std::int32_t node) { return static_cast<std::int64_t>(node) * 4 + 2; }

// Closest point on a triangle by Voronoi regions, with the region reported as the feature (the
// shared DEM formulas: docs/architecture.md section 11). A point exactly on a shared edge is an edge
// hit from both triangles (same key), never a face hit of both.
ClosestFeature closestFeature(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c,
                              const std::array<std::int32_t, 3>& ids, std::int32_t tri) {
  using physics::TriangleRegion;
  const physics::TrianglePoint q = physics::closestOnTriangle(p, a, b, c);
  const auto along = [&](const Vec3& u, const Vec3& w) {
    return Vec3{u[0] + q.t * (w[0] - u[0]), u[1] + q.t * (w[1] - u[1]), u[2] + q.t * (w[2] - u[2])};
  };
  switch (q.region) {
    case TriangleRegion::A: return {a, q.weights, FeatureKind::Vertex, vertexKey(ids[0])};
    case TriangleRegion::B: return {b, q.weights, FeatureKind::Vertex, vertexKey(ids[1])};
    case TriangleRegion::C: return {c, q.weights, FeatureKind::Vertex, vertexKey(ids[2])};
    case TriangleRegion::AB: return {along(a, b), q.weights, FeatureKind::Edge, edgeKey(ids[0], ids[1])};
    case TriangleRegion::AC: return {along(a, c), q.weights, FeatureKind::Edge, edgeKey(ids[0], ids[2])};
    case TriangleRegion::BC: return {along(b, c), q.weights, FeatureKind::Edge, edgeKey(ids[1], ids[2])};
    case TriangleRegion::Face: break;
  }
  const Vec3 ab{b[0] - a[0], b[1] - a[1], b[2] - a[2]}, ac{c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  return {{a[0] + ab[0] * q.v + ac[0] * q.w, a[1] + ab[1] * q.v + ac[1] * q.w, a[2] + ab[2] * q.v + ac[2] * q.w},
          q.weights, FeatureKind::Face, faceKey(tri)};
}

namespace {

// Merges coincident corners into unique nodes (grid-snapped key, exact within the tolerance cell).
TriangleMesh buildMesh(const std::vector<Vec3>& corners, double merge_tolerance) {
  TriangleMesh mesh;
  std::map<std::tuple<long long, long long, long long>, std::int32_t> index;
  std::vector<std::int32_t> ids(corners.size());
  for (std::size_t c = 0; c < corners.size(); ++c) {
    const auto key = std::make_tuple(std::llround(corners[c][0] / merge_tolerance),
                                     std::llround(corners[c][1] / merge_tolerance),
                                     std::llround(corners[c][2] / merge_tolerance));
    auto [it, inserted] = index.emplace(key, static_cast<std::int32_t>(mesh.rest_nodes.size()));
    if (inserted) mesh.rest_nodes.push_back(corners[c]);
    ids[c] = it->second;
  }
  for (std::size_t t = 0; t + 2 < corners.size(); t += 3) {
    if (ids[t] == ids[t + 1] || ids[t] == ids[t + 2] || ids[t + 1] == ids[t + 2]) continue;  // degenerate
    mesh.triangles.push_back({ids[t], ids[t + 1], ids[t + 2]});
  }
  mesh.nodes = mesh.rest_nodes;
  mesh.deformation_velocity.assign(mesh.nodes.size(), Vec3{0, 0, 0});
  return mesh;
}

}  // namespace

TriangleMesh readStl(const std::filesystem::path& file, double scale, double merge_tolerance) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw std::runtime_error(file.string() + ": cannot open STL file");
  std::string content((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  std::vector<Vec3> corners;
  const bool ascii = content.rfind("solid", 0) == 0 && content.find("facet") != std::string::npos;
  if (ascii) {
    std::istringstream text(content);
    std::string word;
    while (text >> word) {
      if (word != "vertex") continue;
      Vec3 v;
      if (!(text >> v[0] >> v[1] >> v[2])) throw std::runtime_error(file.string() + ": malformed 'vertex' line in ASCII STL");
      corners.push_back({v[0] * scale, v[1] * scale, v[2] * scale});
    }
    if (corners.size() % 3 != 0) throw std::runtime_error(file.string() + ": ASCII STL facet without three vertices");
  } else {
    if (content.size() < 84) throw std::runtime_error(file.string() + ": binary STL shorter than its 84-byte header");
    std::uint32_t count = 0;
    std::memcpy(&count, content.data() + 80, 4);
    if (content.size() < 84 + static_cast<std::size_t>(count) * 50)
      throw std::runtime_error(file.string() + ": binary STL truncated (header says " + std::to_string(count) + " triangles)");
    for (std::uint32_t t = 0; t < count; ++t) {
      const char* rec = content.data() + 84 + static_cast<std::size_t>(t) * 50 + 12;  // skip normal
      for (int v = 0; v < 3; ++v) {
        float xyz[3];
        std::memcpy(xyz, rec + 12 * v, 12);
        corners.push_back({xyz[0] * scale, xyz[1] * scale, xyz[2] * scale});
      }
    }
  }
  TriangleMesh mesh = buildMesh(corners, merge_tolerance);
  if (mesh.triangles.empty()) throw std::runtime_error(file.string() + ": STL file has no non-degenerate triangles");
  mesh.name = file.stem().string();
  return mesh;
}

}  // namespace demfem::builtin

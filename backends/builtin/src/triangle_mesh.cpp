#include "demfem/backends/builtin/triangle_mesh.hpp"

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

namespace {
Vec3 sub(const Vec3& a, const Vec3& b) { return {a[0] - b[0], a[1] - b[1], a[2] - b[2]}; }
double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

ClosestFeature vertexHit(const Vec3& v, std::int32_t node, int slot) {
  ClosestFeature f{v, {0, 0, 0}, FeatureKind::Vertex, vertexKey(node)};
  f.weights[slot] = 1;
  return f;
}
ClosestFeature edgeHit(const Vec3& u, const Vec3& w, double t, std::int32_t nu, std::int32_t nw, int su, int sw) {
  ClosestFeature f{{u[0] + t * (w[0] - u[0]), u[1] + t * (w[1] - u[1]), u[2] + t * (w[2] - u[2])},
                   {0, 0, 0}, FeatureKind::Edge, edgeKey(nu, nw)};
  f.weights[su] = 1 - t;
  f.weights[sw] = t;
  return f;
}
}  // namespace

// Closest point on a triangle by Voronoi regions (Ericson, Real-Time Collision Detection, 5.1.5),
// with the region reported as the feature. A point exactly on a shared edge is an edge hit from both
// triangles (same key), never a face hit of both.
ClosestFeature closestFeature(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c,
                              const std::array<std::int32_t, 3>& ids, std::int32_t tri) {
  const Vec3 ab = sub(b, a), ac = sub(c, a), ap = sub(p, a);
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return vertexHit(a, ids[0], 0);
  const Vec3 bp = sub(p, b);
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return vertexHit(b, ids[1], 1);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return edgeHit(a, b, d1 / (d1 - d3), ids[0], ids[1], 0, 1);
  const Vec3 cp = sub(p, c);
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return vertexHit(c, ids[2], 2);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return edgeHit(a, c, d2 / (d2 - d6), ids[0], ids[2], 0, 2);
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0)
    return edgeHit(b, c, (d4 - d3) / ((d4 - d3) + (d5 - d6)), ids[1], ids[2], 1, 2);
  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  return {{a[0] + ab[0] * v + ac[0] * w, a[1] + ab[1] * v + ac[1] * w, a[2] + ab[2] * v + ac[2] * w},
          {1 - v - w, v, w}, FeatureKind::Face, faceKey(tri)};
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

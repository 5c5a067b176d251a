// Triangle-mesh walls of the built-in DEM: tools (the keypoint triangulation shared with the FEM,
// adapter/plate_surface.hpp) and any STL geometry, with rigid motion plus per-node deformation.
//
// Contract
// - Nodes are unique (shared by the triangles that use them); ids 0..n-1 are the coupling API's
//   keypoint ids. Positions are stored in the mesh's LOCAL frame (metres); the bin position is
//   x_bin = origin + x_local + velocity (t - t0) (translation only, as the coupling API's RigidMotion).
// - Contact geometry: closestFeature() returns the point of a triangle nearest to a sphere centre and
//   which feature it lies on (the face interior, one of its edges, one of its vertices). Features are
//   identified mesh-wide (face: triangle id; edge: its two node ids; vertex: node id), so that the
//   same edge seen from its two triangles, or a vertex seen from all its triangles, is one contact:
//   this is how the DEM avoids double counting (docs/architecture.md section 2).
// - Barycentric weights of the contact point (sum 1, non-negative) split a contact force to the three
//   nodes so that total force and moment are conserved.
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace demfem::builtin {

using Vec3 = std::array<double, 3>;

enum class FeatureKind : std::uint8_t { Face = 0, Edge = 1, Vertex = 2 };

struct ClosestFeature {
  Vec3 point;                 // closest point on the triangle (bin frame)
  std::array<double, 3> weights;  // barycentric weights of `point` for nodes a, b, c
  FeatureKind kind;
  std::int64_t key;           // mesh-wide feature id (see featureKey)
};

// Mesh-wide id of a feature: faces, edges and vertices never collide.
std::int64_t faceKey(std::int32_t triangle);
std::int64_t edgeKey(std::int32_t node_a, std::int32_t node_b);
std::int64_t vertexKey(std::int32_t node);

// Closest point on triangle (a, b, c) with node ids `ids`, triangle index `tri`, to point p.
ClosestFeature closestFeature(const Vec3& p, const Vec3& a, const Vec3& b, const Vec3& c,
                              const std::array<std::int32_t, 3>& ids, std::int32_t tri);

struct TriangleMesh {
  std::string name;
  std::vector<Vec3> rest_nodes;       // undeformed local positions (m)
  std::vector<Vec3> nodes;            // current local positions = rest + deformation (m)
  std::vector<Vec3> deformation_velocity; // d(nodes)/dt estimated by the last setNodePositions (m/s)
  std::vector<std::array<std::int32_t, 3>> triangles;
  Vec3 origin{0, 0, 0};               // rigid motion: bin position of the local origin at t0
  Vec3 velocity{0, 0, 0};             // m/s
  double t0 = 0;                      // s
  int material = 0;                   // DEM material index of the wall

  Vec3 offset(double t) const {       // local -> bin translation at time t
    return {origin[0] + velocity[0] * (t - t0), origin[1] + velocity[1] * (t - t0), origin[2] + velocity[2] * (t - t0)};
  }
};

// Reads an STL file (ASCII or binary) and merges coincident vertices (within `merge_tolerance` m)
// into unique nodes. `scale` converts file units to metres. Throws std::runtime_error naming the
// file and the problem (unreadable, truncated, no triangles).
TriangleMesh readStl(const std::filesystem::path& file, double scale = 1.0, double merge_tolerance = 1e-9);

}  // namespace demfem::builtin

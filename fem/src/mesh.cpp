#include "demfem/fem/mesh.hpp"

#include "demfem/adapter/plate_surface.hpp"

#include <fstream>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>

namespace demfem::fem {

int nodesPerElement(ElementType type) { return type == ElementType::Hex20 ? 20 : 10; }

namespace {

// Corner pairs of the mid-edge nodes 8..19 of a C3D20 element (CalculiX order).
constexpr int kHexEdges[12][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6},
                                  {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};

}  // namespace

PlateMesh makePlateMesh(double length, double width, double thickness, double spacing) {
  // The keypoint grid of the DEM side; its corner nodes are ours.
  const adapter::PlateSurface surface = adapter::makePlateSurface(length, width, thickness, spacing);
  const int nx = surface.nx, ny = surface.ny, nz = surface.nz;
  // Nodes on the half-step lattice (2nx-1) x (2ny-1) x (2nz-1): corners have all indices even,
  // mid-edge nodes exactly one odd index (serendipity element: no face or centre nodes).
  const int NX = 2 * nx - 1, NY = 2 * ny - 1, NZ = 2 * nz - 1;
  std::vector<int> lattice(static_cast<std::size_t>(NX) * NY * NZ, -1);
  auto at = [&](int I, int J, int K) -> int& { return lattice[(static_cast<std::size_t>(K) * NY + J) * NX + I]; };
  PlateMesh plate;
  for (int K = 0; K < NZ; ++K)
    for (int J = 0; J < NY; ++J)
      for (int I = 0; I < NX; ++I) {
        if ((I % 2) + (J % 2) + (K % 2) > 1) continue;
        at(I, J, K) = static_cast<int>(plate.mesh.nodes.size());
        plate.mesh.nodes.emplace_back(-width / 2 + width * I / (NX - 1), length * J / (NY - 1),
                                      -thickness / 2 + thickness * K / (NZ - 1));
      }
  for (int k = 0; k + 1 < nz; ++k)
    for (int j = 0; j + 1 < ny; ++j)
      for (int i = 0; i + 1 < nx; ++i) {
        // Corners in CalculiX order: face z = k (counter-clockwise seen from -z... i.e. x, then y),
        // then the same at z = k + 1; right-handed so the Jacobian is positive.
        const int corner[8][3] = {{i, j, k},         {i + 1, j, k},         {i + 1, j + 1, k},
                                  {i, j + 1, k},     {i, j, k + 1},         {i + 1, j, k + 1},
                                  {i + 1, j + 1, k + 1}, {i, j + 1, k + 1}};
        Element e;
        e.type = ElementType::Hex20;
        for (const auto& c : corner) e.nodes.push_back(at(2 * c[0], 2 * c[1], 2 * c[2]));
        for (const auto& edge : kHexEdges) {
          const auto& a = corner[edge[0]];
          const auto& b = corner[edge[1]];
          e.nodes.push_back(at(a[0] + b[0], a[1] + b[1], a[2] + b[2]));
        }
        plate.mesh.elements.push_back(std::move(e));
      }
  plate.keypoint_nodes.reserve(surface.nodes.size());
  for (const auto& g : surface.grid_index) plate.keypoint_nodes.push_back(at(2 * g[0], 2 * g[1], 2 * g[2]));
  return plate;
}

namespace {

// Line-oriented reader that knows where it is, for messages "file:line: what".
class MshReader {
 public:
  explicit MshReader(const std::filesystem::path& file) : file_(file), in_(file) {
    if (!in_) throw std::runtime_error(file.string() + ": cannot open Gmsh mesh file");
  }
  bool next(std::string& line) {
    if (!std::getline(in_, line)) return false;
    ++line_no_;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return true;
  }
  std::string nextRequired(const char* what) {
    std::string line;
    if (!next(line)) fail(std::string("unexpected end of file, expected ") + what);
    return line;
  }
  [[noreturn]] void fail(const std::string& message) const {
    throw std::runtime_error(file_.string() + ":" + std::to_string(line_no_) + ": " + message);
  }
  template <class... T>
  void parse(const std::string& line, const char* what, T&... values) {
    std::istringstream s(line);
    if (!((s >> values) && ...)) fail(std::string("cannot read ") + what + " from '" + line + "'");
  }

  // The number of entity blocks of a $Nodes or $Elements section (`what`: "node" or "element"),
  // from its header line: blocks, entries, lowest tag, highest tag.
  long sectionBlocks(const std::string& what) {
    long blocks = 0, entries = 0, min_tag = 0, max_tag = 0;
    parse(nextRequired((what + " header").c_str()), (what + " section header").c_str(), blocks, entries, min_tag, max_tag);
    return blocks;
  }

  // An entity block's header line: dimension, entity tag, the section's per-block value (nodes:
  // parametric flag, elements: Gmsh element type) and the number of entries.
  struct BlockHeader {
    int dim = 0, entity = 0, value = 0;
    long entries = 0;
  };
  BlockHeader blockHeader(const std::string& what) {
    BlockHeader h;
    const std::string name = what + " block header";
    parse(nextRequired(name.c_str()), name.c_str(), h.dim, h.entity, h.value, h.entries);
    return h;
  }

 private:
  std::filesystem::path file_;
  std::ifstream in_;
  int line_no_ = 0;
};

// Gmsh -> CalculiX node order (index = CalculiX position, value = Gmsh position).
constexpr int kGmshHex20ToCcx[20] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 11, 13, 9, 16, 18, 19, 17, 10, 12, 14, 15};
constexpr int kGmshTet10ToCcx[10] = {0, 1, 2, 3, 4, 5, 6, 7, 9, 8};

}  // namespace

Mesh readGmshMesh(const std::filesystem::path& file, double scale_to_m) {
  if (!(scale_to_m > 0)) throw std::invalid_argument("readGmshMesh: scale_to_m must be > 0");
  MshReader r(file);
  std::map<long, Eigen::Vector3d> node_by_tag;
  struct RawElement {
    ElementType type;
    std::vector<long> tags;  // CalculiX order
  };
  std::vector<RawElement> raw;
  bool format_seen = false;
  std::string line;
  while (r.next(line)) {
    if (line == "$MeshFormat") {
      double version = 0;
      int binary = 0, size_t_bytes = 0;
      r.parse(r.nextRequired("format line"), "version, file type, data size", version, binary, size_t_bytes);
      if (version < 4.1 - 1e-9 || version >= 5) r.fail("Gmsh format " + std::to_string(version) + " is not supported (need 4.1)");
      if (binary != 0) r.fail("binary Gmsh files are not supported (save as ASCII: Mesh.Binary = 0)");
      format_seen = true;
    } else if (line == "$Nodes") {
      if (!format_seen) r.fail("$Nodes before $MeshFormat");
      const long blocks = r.sectionBlocks("node");
      for (long b = 0; b < blocks; ++b) {
        std::vector<long> tags(static_cast<std::size_t>(r.blockHeader("node").entries));
        for (auto& t : tags) r.parse(r.nextRequired("node tag"), "node tag", t);
        for (long t : tags) {
          double x = 0, y = 0, z = 0;
          r.parse(r.nextRequired("node coordinates"), "node coordinates", x, y, z);
          node_by_tag[t] = Eigen::Vector3d(x, y, z) * scale_to_m;
        }
      }
    } else if (line == "$Elements") {
      if (!format_seen) r.fail("$Elements before $MeshFormat");
      const long blocks = r.sectionBlocks("element");
      for (long b = 0; b < blocks; ++b) {
        const auto block = r.blockHeader("element");
        const int gmsh_type = block.value;
        const long n = block.entries;
        const bool keep = block.dim == 3;
        if (keep && gmsh_type != 17 && gmsh_type != 11)
          r.fail("volume element type " + std::to_string(gmsh_type) +
                 " is not supported: use 20-node hexahedra (17) or 10-node tetrahedra (11), "
                 "e.g. Mesh.ElementOrder = 2 and Mesh.SecondOrderIncomplete = 1");
        for (long e = 0; e < n; ++e) {
          const std::string text = r.nextRequired("element");
          if (!keep) continue;
          const ElementType type = gmsh_type == 17 ? ElementType::Hex20 : ElementType::Tet10;
          const int count_nodes = nodesPerElement(type);
          std::istringstream s(text);
          long tag = 0;
          std::vector<long> gmsh_nodes(static_cast<std::size_t>(count_nodes));
          s >> tag;
          for (auto& g : gmsh_nodes) s >> g;
          if (!s) r.fail("element needs a tag and " + std::to_string(count_nodes) + " node tags: '" + text + "'");
          RawElement re{type, std::vector<long>(static_cast<std::size_t>(count_nodes))};
          for (int k = 0; k < count_nodes; ++k)
            re.tags[k] = gmsh_nodes[type == ElementType::Hex20 ? kGmshHex20ToCcx[k] : kGmshTet10ToCcx[k]];
          raw.push_back(std::move(re));
        }
      }
    }
  }
  if (!format_seen) throw std::runtime_error(file.string() + ": no $MeshFormat section: not a Gmsh mesh file");
  if (raw.empty()) throw std::runtime_error(file.string() + ": no 20-node hexahedra or 10-node tetrahedra in the mesh");
  // Keep the nodes the volume elements use, numbered in tag order (deterministic).
  std::map<long, int> index_by_tag;
  for (const auto& e : raw)
    for (long t : e.tags) index_by_tag.emplace(t, 0);
  Mesh mesh;
  for (auto& [tag, index] : index_by_tag) {
    const auto it = node_by_tag.find(tag);
    if (it == node_by_tag.end())
      throw std::runtime_error(file.string() + ": element uses node tag " + std::to_string(tag) + " that $Nodes does not define");
    index = static_cast<int>(mesh.nodes.size());
    mesh.nodes.push_back(it->second);
  }
  for (const auto& e : raw) {
    Element out{e.type, {}};
    for (long t : e.tags) out.nodes.push_back(index_by_tag.at(t));
    mesh.elements.push_back(std::move(out));
  }
  return mesh;
}

}  // namespace demfem::fem

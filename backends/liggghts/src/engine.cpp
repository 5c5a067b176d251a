// The engine's running simulation (engine.hpp): DEM steps, node positions and forces from the tool
// meshes, moving the mesh nodes, and the per-step force hook.
#include "engine.hpp"

#include "demfem/backends/physics/dem_formulas.hpp"

#include <mpi.h>

#include <atom.h>
#include <fix_contact_property_atom_wall.h>
#include <fix_mesh_surface.h>
#include <lammps.h>
#include <library.h>
#include <mesh_mover.h>
#include <modify.h>
#include <tri_mesh.h>
#include <universe.h>
#include <update.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <unistd.h>

namespace demfem::liggghts::detail {

using adapter::CouplingError;
using adapter::ErrorCode;
using adapter::ForceMode;
using adapter::NodeArray;
using adapter::RigidMotion;

// Gives access to a mesh's node array: MeshMover is a friend of the mesh and hands the array to the
// movers LIGGGHTS ships. This class moves nothing by itself and is never registered with the mesh
// (registering a mover after set-up corrupts LIGGGHTS' memory); the backend moves the nodes.
class NodeArrayAccess : public LAMMPS_NS::MeshMover {
 public:
  NodeArrayAccess(LAMMPS_NS::LAMMPS* lmp, LAMMPS_NS::TriMesh* mesh) : MeshMover(lmp, mesh, nullptr) {}
  void post_create() override {}
  void pre_delete() override {}
  void initial_integrate(double, double, double) override {}
  double*** nodes() { return get_nodes(); }
};

ToolState::ToolState() = default;
ToolState::ToolState(ToolState&&) noexcept = default;
ToolState& ToolState::operator=(ToolState&&) noexcept = default;
ToolState::~ToolState() = default;

std::string uniqueWorkDirectoryName(int rank) {
  static std::atomic<int> counter{0};
  return "demfem-liggghts-" + std::to_string(::getpid()) + "-" + std::to_string(counter++) + "-r" +
         std::to_string(rank);
}

Vec3 rigidOffset(const RigidMotion& m, double t) {
  return {m.origin_m[0] + m.velocity_m_s[0] * (t - m.t0_s), m.origin_m[1] + m.velocity_m_s[1] * (t - m.t0_s),
          m.origin_m[2] + m.velocity_m_s[2] * (t - m.t0_s)};
}

namespace {

// The shortest edge of the triangle of keypoints p0, p1, p2 (m).
double shortestEdge(const std::array<Vec3, 3>& p) {
  double shortest = std::numeric_limits<double>::infinity();
  for (std::size_t a = 0; a < 3; ++a) {
    const Vec3& q = p[(a + 1) % 3];
    shortest = std::min(shortest, std::hypot(p[a][0] - q[0], p[a][1] - q[1], p[a][2] - q[2]));
  }
  return shortest;
}

}  // namespace

double Engine::time() const { return static_cast<double>(lmp_->update->ntimestep - start_step_) * dt_; }

std::string Engine::version() const { return std::string("LIGGGHTS-PUBLIC 3.8 (") + lmp_->universe->version + ")"; }

std::int64_t Engine::particleCount() const { return static_cast<std::int64_t>(lmp_->atom->natoms); }

SettledParticles Engine::particles() const { return gatherParticles(lmp_); }

void Engine::command(const std::string& line) { instance_->command(line); }

void Engine::simulate(long long steps) {
  if (steps == 0) {  // refreshes derived data only; the last interval's forces stay as they are
    if (mesh_edited_) command("run 0 pre yes post no");
    mesh_edited_ = false;
    return;
  }
  for (auto& tool : tools_) {
    std::fill(tool.force_sum.begin(), tool.force_sum.end(), 0.0);
    std::fill(tool.force_last.begin(), tool.force_last.end(), 0.0);
  }
  accumulated_steps_ = 0;
  // `pre yes` re-runs LIGGGHTS' set-up: the meshes are re-exchanged and their normals, edge data
  // and neighbour lists recomputed. In 3.8 `pre no` skips all of it, so a deformed or jumped mesh
  // would be used with stale derived data; it is only used when no node moved since the last run.
  command("run " + std::to_string(steps) + (mesh_edited_ ? " pre yes" : " pre no") + " post no");
  mesh_edited_ = false;
}

NodeArray Engine::nodePositions(std::size_t g) {
  auto& tool = tools_[g];
  LAMMPS_NS::TriMesh* mesh = tool.mesh_fix->triMesh();
  const std::size_t n = tool.surface.nodes.size();
  std::vector<double> sum(4 * n, 0.0);  // x, y, z, copies
  const Vec3 offset = rigidOffset(tool.motion, time());
  for (int i = 0; i < mesh->sizeLocal(); ++i) {
    const auto keypoints = copyKeypoints(tool, i);
    for (int j = 0; j < 3; ++j) {
      double node[3];
      mesh->node(i, j, node);
      const auto k = static_cast<std::size_t>(keypoints[j]);
      for (int c = 0; c < 3; ++c) sum[4 * k + c] += node[c] - offset[c];
      sum[4 * k + 3] += 1;
    }
  }
  MPI_Allreduce(MPI_IN_PLACE, sum.data(), static_cast<int>(sum.size()), MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  NodeArray xyz(3 * n);
  for (std::size_t k = 0; k < n; ++k) {
    if (sum[4 * k + 3] < 1)
      throw CouplingError(ErrorCode::Internal, "tool \"" + tool.name + "\": keypoint " + std::to_string(k) +
                                                   " is on no triangle of the LIGGGHTS mesh");
    for (int c = 0; c < 3; ++c) xyz[3 * k + c] = sum[4 * k + c] / sum[4 * k + 3];
  }
  return xyz;
}

NodeArray Engine::nodeForces(std::size_t g, ForceMode mode) {
  const auto& tool = tools_[g];
  NodeArray f = mode == ForceMode::Instantaneous ? tool.force_last : tool.force_sum;
  MPI_Allreduce(MPI_IN_PLACE, f.data(), static_cast<int>(f.size()), MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
  if (mode == ForceMode::IntervalMean && accumulated_steps_ > 0)
    for (double& v : f) v /= static_cast<double>(accumulated_steps_);  // impulse / duration
  return f;
}

Vec3 Engine::meshTotalForce(std::size_t g) {
  Vec3 total{};
  const std::string id = "tool" + std::to_string(g);
  for (int c = 0; c < 3; ++c) {
    auto* value = static_cast<double*>(lammps_extract_fix(lmp_, const_cast<char*>(id.c_str()), 0, 1, c, 0));
    total[static_cast<std::size_t>(c)] = *value;
    std::free(value);
  }
  return total;
}

void Engine::setNodePositions(std::size_t g, const NodeArray& xyz) {
  auto& tool = tools_[g];
  std::vector<double> increment(xyz.size());
  for (std::size_t k = 0; k < tool.surface.nodes.size(); ++k)
    for (std::size_t c = 0; c < 3; ++c) {
      const double target_deformation = xyz[3 * k + c] - tool.surface.nodes[k][c];
      increment[3 * k + c] = target_deformation - tool.deformation[3 * k + c];
    }
  moveCopies(tool, [&increment](std::size_t k) { return Vec3{increment[3 * k], increment[3 * k + 1], increment[3 * k + 2]}; });
  for (std::size_t v = 0; v < xyz.size(); ++v) tool.deformation[v] += increment[v];
}

void Engine::setRigidMotion(std::size_t g, const RigidMotion& motion) {
  auto& tool = tools_[g];
  const double t = time();
  const Vec3 before = rigidOffset(tool.motion, t);
  const Vec3 after = rigidOffset(motion, t);
  const Vec3 jump{after[0] - before[0], after[1] - before[1], after[2] - before[2]};
  if (jump != Vec3{0, 0, 0}) moveCopies(tool, [&jump](std::size_t) { return jump; });  // old motion: copies match
  tool.motion = motion;
  const std::string id = "tool" + std::to_string(g);
  const char* axes[3] = {"_vx", "_vy", "_vz"};
  for (int c = 0; c < 3; ++c)
    command("variable " + id + axes[c] + " equal " + exact(motion.velocity_m_s[static_cast<std::size_t>(c)]));
}

// Releases the node accesses before the instance they belong to, then the work directory.
void Engine::release() {
  for (auto& tool : tools_) tool.node_access.reset();
  instance_.reset();
  lmp_ = nullptr;
  std::error_code ignored;
  std::filesystem::remove_all(work_dir_, ignored);
}

void Engine::findMesh(std::size_t g) {
  auto& tool = tools_[g];
  const std::string id = "tool" + std::to_string(g);
  tool.mesh_fix = dynamic_cast<LAMMPS_NS::FixMeshSurface*>(lmp_->modify->find_fix_id(id.c_str()));
  if (!tool.mesh_fix || !tool.mesh_fix->meshforceContactStress())
    throw CouplingError(ErrorCode::Internal, "LIGGGHTS mesh of tool \"" + tool.name + "\" not found");
  tool.node_access = std::make_unique<NodeArrayAccess>(lmp_, tool.mesh_fix->triMesh());
}

Vec3 Engine::keypoint(const ToolState& tool, std::size_t k) const {
  return {tool.surface.nodes[k][0] + tool.deformation[3 * k], tool.surface.nodes[k][1] + tool.deformation[3 * k + 1],
          tool.surface.nodes[k][2] + tool.deformation[3 * k + 2]};
}

// Keypoint ids of the three nodes of triangle copy i (local or ghost) of the tool's mesh: the
// triangle is found by its id, each node is matched to the nearest of that triangle's keypoints.
std::array<std::int32_t, 3> Engine::copyKeypoints(const ToolState& tool, int i) const {
  LAMMPS_NS::TriMesh* mesh = tool.mesh_fix->triMesh();
  const long t = mesh->id(i) - tool.id_offset;
  if (t < 0 || t >= static_cast<long>(tool.surface.triangles.size()))
    throw CouplingError(ErrorCode::Internal, "tool \"" + tool.name + "\": LIGGGHTS triangle id " +
                                                 std::to_string(mesh->id(i)) + " is not a keypoint triangle");
  const auto& tri = tool.surface.triangles[static_cast<std::size_t>(t)];
  const Vec3 offset = rigidOffset(tool.motion, time());
  std::array<Vec3, 3> corners;
  for (std::size_t a = 0; a < 3; ++a) corners[a] = keypoint(tool, static_cast<std::size_t>(tri[a]));
  const double tolerance = 0.1 * shortestEdge(corners);
  std::array<std::int32_t, 3> result{};
  for (int j = 0; j < 3; ++j) {
    double node[3];
    mesh->node(i, j, node);
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t a = 0; a < 3; ++a) {
      const Vec3& p = corners[a];
      const double d = std::hypot(node[0] - offset[0] - p[0], node[1] - offset[1] - p[1], node[2] - offset[2] - p[2]);
      if (d < best) {
        best = d;
        result[static_cast<std::size_t>(j)] = tri[a];
      }
    }
    if (best > tolerance)
      throw CouplingError(ErrorCode::Internal, "tool \"" + tool.name + "\": LIGGGHTS triangle " + std::to_string(t) +
                                                   " does not match the keypoint triangle (node off by " +
                                                   std::to_string(best) + " m)");
  }
  return result;
}

// Moves every local and ghost node copy of the tool by displacement(keypoint), then refreshes the
// element centres and bounding radii over local and ghost elements; normals and neighbour data are
// recomputed by the `pre yes` set-up of the next run.
void Engine::moveCopies(ToolState& tool, const std::function<Vec3(std::size_t)>& displacement) {
  LAMMPS_NS::TriMesh* mesh = tool.mesh_fix->triMesh();
  const int all = mesh->sizeLocal() + mesh->sizeGhost();
  std::vector<std::array<std::int32_t, 3>> keypoints(static_cast<std::size_t>(all));
  for (int i = 0; i < all; ++i) keypoints[static_cast<std::size_t>(i)] = copyKeypoints(tool, i);
  double*** nodes = tool.node_access->nodes();
  for (int i = 0; i < all; ++i)
    for (int j = 0; j < 3; ++j) {
      const Vec3 d = displacement(static_cast<std::size_t>(keypoints[static_cast<std::size_t>(i)][j]));
      for (int c = 0; c < 3; ++c) nodes[i][j][c] += d[static_cast<std::size_t>(c)];
    }
  mesh->updateCenterRbound(0, all);
  mesh_edited_ = true;
}

void Engine::afterForces(void* self, std::int64_t, int nlocal, int*, double** x, double** fexternal) {
  static_cast<Engine*>(self)->accumulate(nlocal, x, fexternal);
}

// Every DEM step (post_force): the contact forces of this step on each tool, split to keypoints.
void Engine::accumulate(int nlocal, double** x, double** fexternal) {
  for (int i = 0; i < nlocal; ++i) fexternal[i][0] = fexternal[i][1] = fexternal[i][2] = 0;  // adds nothing
  if (lmp_->update->setupflag) return;  // set-up recomputes the last step's forces: not a new step
  const double t = time();
  for (auto& tool : tools_) accumulateTool(tool, nlocal, x, t);
  ++accumulated_steps_;
}

// This step's contact forces on one tool (force_last), added to the interval's sum (force_sum).
void Engine::accumulateTool(ToolState& tool, int nlocal, double** x, double t) {
  std::fill(tool.force_last.begin(), tool.force_last.end(), 0.0);
  LAMMPS_NS::FixContactPropertyAtomWall* contacts = tool.mesh_fix->meshforceContactStress();
  const Vec3 offset = rigidOffset(tool.motion, t);
  for (int i = 0; i < nlocal; ++i) {
    const int n = contacts->n_partner(i);
    for (int p = 0; p < n; ++p) {
      const long tri = contacts->partner(i, p) - tool.id_offset;
      const double* stored = contacts->contacthistory(i, p);  // force on the particle, delta, v
      const auto& nodes = tool.surface.triangles[static_cast<std::size_t>(tri)];
      const Vec3 centre{x[i][0] - offset[0], x[i][1] - offset[1], x[i][2] - offset[2]};
      // The contact point: the triangle's point closest to the centre (docs/architecture.md section 11).
      const Vec3 w = physics::closestOnTriangle(centre, keypoint(tool, static_cast<std::size_t>(nodes[0])),
                                                keypoint(tool, static_cast<std::size_t>(nodes[1])),
                                                keypoint(tool, static_cast<std::size_t>(nodes[2])))
                         .weights;
      for (int a = 0; a < 3; ++a) {
        const auto k = 3 * static_cast<std::size_t>(nodes[static_cast<std::size_t>(a)]);
        for (int c = 0; c < 3; ++c) tool.force_last[k + static_cast<std::size_t>(c)] -= w[static_cast<std::size_t>(a)] * stored[c];
      }
    }
  }
  for (std::size_t v = 0; v < tool.force_sum.size(); ++v) tool.force_sum[v] += tool.force_last[v];
}

}  // namespace demfem::liggghts::detail

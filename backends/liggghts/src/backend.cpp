// The liggghts backend: LIGGGHTS-PUBLIC 3.8 in-process, one instance per MPI rank (backend.hpp).
// This file: the engine (one rank's part of the simulation), the leader/follower broadcast and the
// facade; the MPI session, the instance and the settled soil are in session.hpp. LIGGGHTS and MPI
// headers stay in the .cpp files (pimpl): nothing of them leaks into our headers.
#include "demfem/backends/liggghts/backend.hpp"

#include "demfem/adapter/settled_soil.hpp"
#include "demfem/backends/liggghts/input_deck.hpp"
#include "demfem/backends/physics/dem_formulas.hpp"

#include "session.hpp"

#include <mpi.h>

#include <atom.h>
#include <fix_contact_property_atom_wall.h>
#include <fix_external.h>
#include <fix_mesh_surface.h>
#include <input.h>
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
#include <cstring>
#include <filesystem>
#include <limits>
#include <map>
#include <optional>
#include <unistd.h>

namespace demfem::liggghts {

using namespace detail;

namespace {

using adapter::CouplingError;
using adapter::ErrorCode;
using adapter::ForceMode;
using adapter::NodeArray;
using adapter::RigidMotion;
using Vec3 = std::array<double, 3>;

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

struct ToolState {
  std::string name;
  adapter::ToolSurface surface;
  LAMMPS_NS::FixMeshSurface* mesh_fix = nullptr;
  std::unique_ptr<NodeArrayAccess> node_access;
  int id_offset = 0;                 // LIGGGHTS triangle id of surface triangle 0
  RigidMotion motion;
  std::vector<double> deformation;   // n x 3, local frame: current keypoint - undeformed keypoint
  std::vector<double> force_sum;     // n x 3, sum over the steps of the current interval
  std::vector<double> force_last;    // n x 3, the last step
};

std::string uniqueWorkDirectoryName(int rank) {
  static std::atomic<int> counter{0};
  return "demfem-liggghts-" + std::to_string(::getpid()) + "-" + std::to_string(counter++) + "-r" +
         std::to_string(rank);
}

// One rank's part of the LIGGGHTS simulation of a study. Every method except time() and the
// accessors is collective: all ranks call it in the same order with the same arguments.
class Engine {
 public:
  Engine(const study::Study& study, const BackendOptions& options)
      : work_dir_(std::filesystem::temp_directory_path() / uniqueWorkDirectoryName(worldRank())) {
    std::filesystem::create_directories(work_dir_);
    try {
      build(study, options);
    } catch (...) {
      release();
      throw;
    }
  }
  ~Engine() { release(); }
  Engine(const Engine&) = delete;
  Engine& operator=(const Engine&) = delete;

  double timeStep() const { return dt_; }
  double time() const { return static_cast<double>(lmp_->update->ntimestep - start_step_) * dt_; }
  std::string version() const { return std::string("LIGGGHTS-PUBLIC 3.8 (") + lmp_->universe->version + ")"; }
  std::size_t toolCount() const { return tools_.size(); }
  const ToolState& tool(std::size_t g) const { return tools_[g]; }

  void simulate(long long steps) {
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

  // Keypoint positions of tool g in its local frame, merged from the triangle copies of all ranks.
  NodeArray nodePositions(std::size_t g) {
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

  // Force of the particles on the keypoints of tool g, summed over the ranks.
  NodeArray nodeForces(std::size_t g, ForceMode mode) {
    const auto& tool = tools_[g];
    NodeArray f = mode == ForceMode::Instantaneous ? tool.force_last : tool.force_sum;
    MPI_Allreduce(MPI_IN_PLACE, f.data(), static_cast<int>(f.size()), MPI_DOUBLE, MPI_SUM, MPI_COMM_WORLD);
    if (mode == ForceMode::IntervalMean && accumulated_steps_ > 0)
      for (double& v : f) v /= static_cast<double>(accumulated_steps_);  // impulse / duration
    return f;
  }

  // Total force on tool g from LIGGGHTS' own stress mesh (fix mesh/surface/stress), last step (N).
  Vec3 meshTotalForce(std::size_t g) {
    Vec3 total{};
    const std::string id = "tool" + std::to_string(g);
    for (int c = 0; c < 3; ++c) {
      auto* value = static_cast<double*>(lammps_extract_fix(lmp_, const_cast<char*>(id.c_str()), 0, 1, c, 0));
      total[static_cast<std::size_t>(c)] = *value;
      std::free(value);
    }
    return total;
  }

  std::int64_t particleCount() const { return static_cast<std::int64_t>(lmp_->atom->natoms); }
  SettledParticles particles() const { return gatherParticles(lmp_); }
  SoilOrigin soilOrigin() const { return {soil_file_, soil_deposited_}; }
  const std::string& soilRecord() const { return soil_record_; }

  void setNodePositions(std::size_t g, const NodeArray& xyz) {
    auto& tool = tools_[g];
    std::vector<double> increment(xyz.size());
    for (std::size_t k = 0; k < tool.surface.nodes.size(); ++k)
      for (std::size_t c = 0; c < 3; ++c) {
        const double target_deformation = xyz[3 * k + c] - tool.surface.nodes[k][c];
        increment[3 * k + c] = target_deformation - tool.deformation[3 * k + c];
      }
    moveCopies(tool, [&increment](std::size_t k) {
      return Vec3{increment[3 * k], increment[3 * k + 1], increment[3 * k + 2]};
    });
    for (std::size_t v = 0; v < xyz.size(); ++v) tool.deformation[v] += increment[v];
  }

  void setRigidMotion(std::size_t g, const RigidMotion& motion) {
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

 private:
  void command(const std::string& line) { instance_->command(line); }

  void build(const study::Study& study, const BackendOptions& options) {
    const InputDeck deck = translateStudy(study, work_dir_);  // throws before LIGGGHTS sees anything
    dt_ = deck.time_step_s;
    for (std::size_t g = 0; g < study.tools.size(); ++g) {
      ToolState tool;
      tool.name = study.tools[g].name;
      tool.surface = toolSurface(study, g);
      tool.motion.origin_m = toolStartOrigin(study, g);
      const std::size_t values = 3 * tool.surface.nodes.size();
      tool.deformation.assign(values, 0.0);
      tool.force_sum.assign(values, 0.0);
      tool.force_last.assign(values, 0.0);
      writeToolStl(tool.surface, tool.motion.origin_m, work_dir_ / ("tool" + std::to_string(g) + ".stl"));
      tools_.push_back(std::move(tool));
    }
    for (const auto* spheres : {&options.probes, &options.settled_soil})
      for (const auto& sphere : *spheres) {
        const std::string what = spheres == &options.probes ? "probe sphere" : "settled-soil particle";
        if (!std::any_of(study.soil.layers.begin(), study.soil.layers.end(),
                         [&sphere](const study::Layer& l) { return l.material == sphere.material; }))
          throw CouplingError(ErrorCode::BadRequest, what + " material \"" + sphere.material +
                                                         "\" is not a particle material of the study");
        if (!(sphere.radius_m > 0)) throw CouplingError(ErrorCode::BadRequest, what + " radius must be positive");
      }

    if (options.probes.empty()) {
      // The settled soil is read from its file or deposited in an instance of its own, so that the
      // simulation below starts from the same state either way (positions only, at rest).
      const SettledParticles soil =
          options.settled_soil.empty() ? settledSoil(study, deck, options) : givenSoil(study, options.settled_soil);
      openMainInstance(deck);
      command("fix integrate all nve/sphere");
      std::map<int, double> density_of_type;
      for (const auto& layer : study.soil.layers)
        density_of_type[atomType(study, layer.material)] = study.material(layer.material).density_kg_m3;
      for (std::size_t i = 0; i < soil.size(); i += kParticleValues)
        addSphere(static_cast<int>(soil[i + 4]), {soil[i], soil[i + 1], soil[i + 2]}, soil[i + 3],
                  density_of_type.at(static_cast<int>(soil[i + 4])));
      if (lmp_->atom->natoms != static_cast<LAMMPS_NS::bigint>(soil.size() / kParticleValues))
        throw CouplingError(ErrorCode::Internal, "LIGGGHTS created " + std::to_string(lmp_->atom->natoms) + " of the " +
                                                     std::to_string(soil.size() / kParticleValues) + " settled particles");
      for (const auto& line : deck.tool_clearance) command(line);
    } else {
      openMainInstance(deck);
      for (const auto& probe : options.probes)
        addSphere(atomType(study, probe.material), probe.centre_m, probe.radius_m,
                  study.material(probe.material).density_kg_m3);
    }

    for (const auto& line : deck.tools) command(line);
    start_step_ = lmp_->update->ntimestep;
    for (std::size_t g = 0; g < tools_.size(); ++g) findMesh(g);
    // The per-step hook: fix external calls afterForces() in post_force, after the tool wall (defined
    // earlier) has stored this step's contact forces.
    command("fix demfem_node_forces all external pf/callback 1 1");
    auto* hook = dynamic_cast<LAMMPS_NS::FixExternal*>(lmp_->modify->find_fix_id("demfem_node_forces"));
    if (!hook) throw CouplingError(ErrorCode::Internal, "LIGGGHTS did not create the node-force hook (fix external)");
    hook->set_callback(&Engine::afterForces, this);
    // Set-up without a step: distributes the meshes over the ranks (before it every rank holds all).
    command("run 0 post no");
    for (std::size_t g = 0; g < tools_.size(); ++g) checkMesh(g);
    mesh_edited_ = false;
  }

  void openMainInstance(const InputDeck& deck) {
    instance_ = std::make_unique<Instance>(work_dir_, "main");
    lmp_ = instance_->get();
    for (const auto& line : deck.setup) command(line);
  }

  // Adds a sphere at rest (bin frame, m; kg/m^3). LIGGGHTS numbers the atoms 1, 2, ... in creation order.
  void addSphere(int type, const Vec3& centre, double radius, double density) {
    command("create_atoms " + std::to_string(type) + " single " + exact(centre[0]) + " " + exact(centre[1]) + " " +
            exact(centre[2]) + " units box");
    command("set atom " + std::to_string(lmp_->atom->natoms) + " diameter " + exact(2 * radius) + " density " +
            exact(density));
  }

  // The settled soil of the study: read from adapter::settledSoilFile() in soilDirectory() (rank 0
  // reads and broadcasts), or, when the file is missing and the study deposits with LIGGGHTS,
  // deposited in an instance of its own and written there (rank 0 writes).
  SettledParticles settledSoil(const study::Study& study, const InputDeck& deck, const BackendOptions& options) {
    soil_file_ = adapter::settledSoilFile(study, soilDirectory(options));
    adapter::SettledSoil soil;
    int status = static_cast<int>(SoilFileStatus::Missing);
    std::string problem;
    if (worldRank() == 0 && std::filesystem::exists(soil_file_)) {
      try {
        soil = adapter::readSettledSoil(soil_file_, study);
        status = static_cast<int>(SoilFileStatus::Loaded);
      } catch (const std::exception& e) {
        status = static_cast<int>(SoilFileStatus::Damaged);
        problem = e.what();
      }
    }
    MPI_Bcast(&status, 1, MPI_INT, 0, MPI_COMM_WORLD);
    if (status == static_cast<int>(SoilFileStatus::Damaged))
      throw CouplingError(ErrorCode::BadRequest, worldRank() == 0 ? problem : "rank 0 cannot read " + soil_file_.string());
    soil_deposited_ = status == static_cast<int>(SoilFileStatus::Missing);
    if (soil_deposited_) {
      if (study.soil.deposition_backend != capabilities().name)
        throw CouplingError(ErrorCode::BadRequest,
                            "liggghts backend: no settled soil " + soil_file_.string() + "; the study deposits it with " +
                                study.soil.deposition_backend +
                                " (/soil/deposition/backend): run `demfem deposit` on the study first");
      soil = depositInInstance(study, deck, work_dir_);
      int written = 1;
      if (worldRank() == 0) try {
          adapter::writeSettledSoil(soil_file_, soil);
        } catch (const std::exception& e) {
          written = 0;
          problem = e.what();
        }
      MPI_Bcast(&written, 1, MPI_INT, 0, MPI_COMM_WORLD);  // every rank fails alike, none waits forever
      if (!written)
        throw CouplingError(ErrorCode::Internal, worldRank() == 0 ? problem : "rank 0 cannot write " + soil_file_.string());
    }
    SettledParticles particles;
    if (worldRank() == 0) {
      soil_record_ = adapter::soilRecordJson(soil, soil_file_, adapter::settledSoilChecksum(soil_file_));
      particles = fromNeutral(study, soil);
    }
    auto count = static_cast<std::uint64_t>(particles.size());
    MPI_Bcast(&count, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
    particles.resize(count);
    MPI_Bcast(particles.data(), static_cast<int>(count), MPI_DOUBLE, 0, MPI_COMM_WORLD);
    return particles;
  }

  static SettledParticles givenSoil(const study::Study& study, const std::vector<Sphere>& spheres) {
    SettledParticles particles;
    for (const auto& p : spheres)
      particles.insert(particles.end(), {p.centre_m[0], p.centre_m[1], p.centre_m[2], p.radius_m,
                                         static_cast<double>(atomType(study, p.material))});
    return particles;
  }

  void findMesh(std::size_t g) {
    auto& tool = tools_[g];
    const std::string id = "tool" + std::to_string(g);
    tool.mesh_fix = dynamic_cast<LAMMPS_NS::FixMeshSurface*>(lmp_->modify->find_fix_id(id.c_str()));
    if (!tool.mesh_fix || !tool.mesh_fix->meshforceContactStress())
      throw CouplingError(ErrorCode::Internal, "LIGGGHTS mesh of tool \"" + tool.name + "\" not found");
    tool.node_access = std::make_unique<NodeArrayAccess>(lmp_, tool.mesh_fix->triMesh());
  }

  // Checks that the distributed mesh holds the keypoint triangles, each once, and finds the id offset.
  void checkMesh(std::size_t g) {
    auto& tool = tools_[g];
    LAMMPS_NS::TriMesh* mesh = tool.mesh_fix->triMesh();
    int lowest = std::numeric_limits<int>::max();
    long long owned = mesh->sizeLocal();
    for (int i = 0; i < mesh->sizeLocal(); ++i) lowest = std::min(lowest, mesh->id(i));
    MPI_Allreduce(MPI_IN_PLACE, &lowest, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
    MPI_Allreduce(MPI_IN_PLACE, &owned, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
    tool.id_offset = lowest;
    if (owned != static_cast<long long>(tool.surface.triangles.size()))
      throw CouplingError(ErrorCode::Internal, "LIGGGHTS mesh of tool \"" + tool.name + "\" has " +
                                                   std::to_string(owned) + " triangles over all ranks, the keypoint "
                                                   "surface " + std::to_string(tool.surface.triangles.size()));
    const int all = mesh->sizeLocal() + mesh->sizeGhost();
    for (int i = 0; i < all; ++i) copyKeypoints(tool, i);  // throws on a mismatch
  }

  static Vec3 rigidOffset(const RigidMotion& m, double t) {
    return {m.origin_m[0] + m.velocity_m_s[0] * (t - m.t0_s), m.origin_m[1] + m.velocity_m_s[1] * (t - m.t0_s),
            m.origin_m[2] + m.velocity_m_s[2] * (t - m.t0_s)};
  }

  // Current local-frame position of keypoint k (undeformed + deformation).
  Vec3 keypoint(const ToolState& tool, std::size_t k) const {
    return {tool.surface.nodes[k][0] + tool.deformation[3 * k], tool.surface.nodes[k][1] + tool.deformation[3 * k + 1],
            tool.surface.nodes[k][2] + tool.deformation[3 * k + 2]};
  }

  // Keypoint ids of the three nodes of triangle copy i (local or ghost) of the tool's mesh: the
  // triangle is found by its id, each node is matched to the nearest of that triangle's keypoints.
  std::array<std::int32_t, 3> copyKeypoints(const ToolState& tool, int i) const {
    LAMMPS_NS::TriMesh* mesh = tool.mesh_fix->triMesh();
    const long t = mesh->id(i) - tool.id_offset;
    if (t < 0 || t >= static_cast<long>(tool.surface.triangles.size()))
      throw CouplingError(ErrorCode::Internal, "tool \"" + tool.name + "\": LIGGGHTS triangle id " +
                                                   std::to_string(mesh->id(i)) + " is not a keypoint triangle");
    const auto& tri = tool.surface.triangles[static_cast<std::size_t>(t)];
    const Vec3 offset = rigidOffset(tool.motion, time());
    double shortest_edge = std::numeric_limits<double>::infinity();
    for (int a = 0; a < 3; ++a) {
      const Vec3 p = keypoint(tool, static_cast<std::size_t>(tri[static_cast<std::size_t>(a)]));
      const Vec3 q = keypoint(tool, static_cast<std::size_t>(tri[static_cast<std::size_t>((a + 1) % 3)]));
      shortest_edge = std::min(shortest_edge, std::hypot(p[0] - q[0], p[1] - q[1], p[2] - q[2]));
    }
    const double tolerance = 0.1 * shortest_edge;
    std::array<std::int32_t, 3> result{};
    for (int j = 0; j < 3; ++j) {
      double node[3];
      mesh->node(i, j, node);
      double best = std::numeric_limits<double>::infinity();
      for (const std::int32_t k : tri) {
        const Vec3 p = keypoint(tool, static_cast<std::size_t>(k));
        const double d = std::hypot(node[0] - offset[0] - p[0], node[1] - offset[1] - p[1], node[2] - offset[2] - p[2]);
        if (d < best) {
          best = d;
          result[static_cast<std::size_t>(j)] = k;
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
  template <typename Displacement>
  void moveCopies(ToolState& tool, Displacement displacement) {
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

  static void afterForces(void* self, LAMMPS_NS::bigint, int nlocal, int*, double** x, double** fexternal) {
    static_cast<Engine*>(self)->accumulate(nlocal, x, fexternal);
  }

  // Every DEM step (post_force): the contact forces of this step on each tool, split to keypoints.
  void accumulate(int nlocal, double** x, double** fexternal) {
    for (int i = 0; i < nlocal; ++i) fexternal[i][0] = fexternal[i][1] = fexternal[i][2] = 0;  // adds nothing
    if (lmp_->update->setupflag) return;  // set-up recomputes the last step's forces: not a new step
    const double t = time();
    for (auto& tool : tools_) {
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
    ++accumulated_steps_;
  }

  void release() {
    for (auto& tool : tools_) tool.node_access.reset();
    instance_.reset();
    lmp_ = nullptr;
    std::error_code ignored;
    std::filesystem::remove_all(work_dir_, ignored);
  }

  std::filesystem::path work_dir_;
  std::unique_ptr<Instance> instance_;
  LAMMPS_NS::LAMMPS* lmp_ = nullptr;  // instance_'s
  std::filesystem::path soil_file_;
  bool soil_deposited_ = false;
  std::string soil_record_;  // adapter::soilRecordJson() of the soil file (rank 0)
  std::vector<ToolState> tools_;
  double dt_ = 0;
  LAMMPS_NS::bigint start_step_ = 0;
  long long accumulated_steps_ = 0;
  bool mesh_edited_ = true;
};


// --- leader/follower: rank 0 broadcasts each collective operation, the other ranks replay it ---

enum class Op : std::int32_t { Simulate = 1, NodePositions, NodeForces, SetNodePositions, SetRigidMotion, Shutdown };

struct OpHeader {
  Op op = Op::Shutdown;
  std::int32_t geometry = 0;
  std::int32_t force_mode = 0;
  std::int64_t steps = 0;
  std::int64_t payload = 0;  // number of doubles broadcast after the header
};

bool multipleRanks() {
  int size = 1;
  MPI_Comm_size(MPI_COMM_WORLD, &size);
  return size > 1;
}

// Broadcast from rank 0 of a header and its payload (a no-op on a single rank).
void broadcast(OpHeader& header, std::vector<double>& payload) {
  if (!multipleRanks()) return;
  MPI_Bcast(&header, sizeof(OpHeader), MPI_BYTE, 0, MPI_COMM_WORLD);
  payload.resize(static_cast<std::size_t>(header.payload));
  if (header.payload > 0) MPI_Bcast(payload.data(), static_cast<int>(header.payload), MPI_DOUBLE, 0, MPI_COMM_WORLD);
}

std::vector<double> motionPayload(const RigidMotion& m) {
  return {m.origin_m[0], m.origin_m[1], m.origin_m[2], m.velocity_m_s[0], m.velocity_m_s[1], m.velocity_m_s[2], m.t0_s};
}

RigidMotion motionFromPayload(const std::vector<double>& p) {
  RigidMotion m;
  m.origin_m = {p[0], p[1], p[2]};
  m.velocity_m_s = {p[3], p[4], p[5]};
  m.t0_s = p[6];
  return m;
}

// Executes one broadcast operation on this rank's engine.
void execute(Engine& engine, const OpHeader& header, const std::vector<double>& payload) {
  const auto g = static_cast<std::size_t>(header.geometry);
  switch (header.op) {
    case Op::Simulate: engine.simulate(header.steps); break;
    case Op::NodePositions: engine.nodePositions(g); break;
    case Op::NodeForces: engine.nodeForces(g, static_cast<ForceMode>(header.force_mode)); break;
    case Op::SetNodePositions: engine.setNodePositions(g, payload); break;
    case Op::SetRigidMotion: engine.setRigidMotion(g, motionFromPayload(payload)); break;
    case Op::Shutdown: break;
  }
}

void requireFinite(const std::vector<double>& values, const std::string& what) {
  for (std::size_t v = 0; v < values.size(); ++v)
    if (!std::isfinite(values[v]))
      throw CouplingError(ErrorCode::BadRequest, what + ": value " + std::to_string(v) + " is not finite");
}

// The coupling API on rank 0: checks arguments, broadcasts the operation, runs it locally.
class LiggghtsBackend final : public adapter::CouplingApi {
 public:
  LiggghtsBackend(const study::Study& study, const BackendOptions& options)
      : engine_(std::make_unique<Engine>(study, options)) {}
  ~LiggghtsBackend() override {
    try {
      shutdown();
    } catch (...) {  // a destructor must not throw; followers are released by the broadcast above
    }
  }

  adapter::BackendInfo info() override {
    auto& e = live();
    adapter::BackendInfo i;
    i.backend = "liggghts";
    i.version = e.version();
    i.dem_time_step_s = e.timeStep();
    i.soil_json = e.soilRecord();
    return i;
  }

  std::vector<adapter::GeometryInfo> geometries() override {
    auto& e = live();
    std::vector<adapter::GeometryInfo> list;
    for (std::size_t g = 0; g < e.toolCount(); ++g) {
      const auto& tool = e.tool(g);
      list.push_back({tool.name, static_cast<std::int32_t>(tool.surface.nodes.size()), tool.surface.triangles});
    }
    return list;
  }

  double time() override { return live().time(); }

  NodeArray nodePositions(const std::string& geometry) override {
    OpHeader h{Op::NodePositions, index(geometry), 0, 0, 0};
    std::vector<double> none;
    broadcast(h, none);
    return live().nodePositions(static_cast<std::size_t>(h.geometry));
  }

  NodeArray nodeForces(const std::string& geometry, ForceMode mode) override {
    OpHeader h{Op::NodeForces, index(geometry), static_cast<std::int32_t>(mode), 0, 0};
    std::vector<double> none;
    broadcast(h, none);
    return live().nodeForces(static_cast<std::size_t>(h.geometry), mode);
  }

  void setNodePositions(const std::string& geometry, const NodeArray& xyz) override {
    const std::int32_t g = index(geometry);
    const std::size_t expected = 3 * live().tool(static_cast<std::size_t>(g)).surface.nodes.size();
    if (xyz.size() != expected)
      throw CouplingError(ErrorCode::SizeMismatch, "setNodePositions(\"" + geometry + "\"): " +
                                                       std::to_string(xyz.size()) + " values, expected " +
                                                       std::to_string(expected) + " (n x 3)");
    requireFinite(xyz, "setNodePositions(\"" + geometry + "\")");
    OpHeader h{Op::SetNodePositions, g, 0, 0, static_cast<std::int64_t>(xyz.size())};
    std::vector<double> payload = xyz;
    broadcast(h, payload);
    live().setNodePositions(static_cast<std::size_t>(g), xyz);
  }

  void simulate(double duration_s) override {
    auto& e = live();
    if (!(duration_s >= 0) || !std::isfinite(duration_s))
      throw CouplingError(ErrorCode::BadRequest, "simulate: duration must be finite and >= 0 s, got " +
                                                     std::to_string(duration_s));
    OpHeader h{Op::Simulate, 0, 0, std::llround(duration_s / e.timeStep()), 0};
    std::vector<double> none;
    broadcast(h, none);
    e.simulate(h.steps);
    for (std::size_t g = 0; g < e.toolCount(); ++g)
      for (double v : e.tool(g).force_last)
        if (!std::isfinite(v))
          throw CouplingError(ErrorCode::SimulationFailed, "LIGGGHTS produced a non-finite force on tool \"" +
                                                               e.tool(g).name + "\"; reduce the DEM time step");
  }

  RigidMotion rigidMotion(const std::string& geometry) override {
    return live().tool(static_cast<std::size_t>(index(geometry))).motion;
  }

  void setRigidMotion(const std::string& geometry, const RigidMotion& motion) override {
    std::vector<double> payload = motionPayload(motion);
    requireFinite(payload, "setRigidMotion(\"" + geometry + "\")");
    OpHeader h{Op::SetRigidMotion, index(geometry), 0, 0, static_cast<std::int64_t>(payload.size())};
    broadcast(h, payload);
    live().setRigidMotion(static_cast<std::size_t>(h.geometry), motion);
  }

  void checkpoint(const std::filesystem::path&) override {
    throw CouplingError(ErrorCode::Unsupported, "the liggghts backend does not offer checkpoints");
  }
  void restore(const std::filesystem::path&) override {
    throw CouplingError(ErrorCode::Unsupported, "the liggghts backend does not offer checkpoints");
  }

  std::array<double, 3> meshTotalForce(const std::string& geometry) {
    return live().meshTotalForce(static_cast<std::size_t>(index(geometry)));
  }

  std::int64_t particleCount() { return live().particleCount(); }
  SoilOrigin soilOrigin() { return live().soilOrigin(); }
  std::vector<std::array<double, 4>> particles() {
    if (multipleRanks())
      throw CouplingError(ErrorCode::Unsupported, "particle positions are only offered on a single MPI rank");
    const SettledParticles all = live().particles();
    std::vector<std::array<double, 4>> xyzr;
    for (std::size_t i = 0; i < all.size(); i += kParticleValues) xyzr.push_back({all[i], all[i + 1], all[i + 2], all[i + 3]});
    return xyzr;
  }

  void shutdown() override {
    if (!engine_) return;
    OpHeader h{Op::Shutdown, 0, 0, 0, 0};
    std::vector<double> none;
    broadcast(h, none);
    engine_.reset();
  }

 private:
  Engine& live() {
    if (!engine_) throw CouplingError(ErrorCode::BadRequest, "the liggghts backend was shut down");
    return *engine_;
  }

  std::int32_t index(const std::string& geometry) {
    auto& e = live();
    for (std::size_t g = 0; g < e.toolCount(); ++g)
      if (e.tool(g).name == geometry) return static_cast<std::int32_t>(g);
    throw CouplingError(ErrorCode::UnknownGeometry, "unknown geometry \"" + geometry + "\"");
  }

  std::unique_ptr<Engine> engine_;
};

}  // namespace

std::unique_ptr<adapter::CouplingApi> makeBackend(const study::Study& study) { return makeBackend(study, {}); }

std::unique_ptr<adapter::CouplingApi> makeBackend(const study::Study& study, const BackendOptions& options) {
  ensureMpi();
  return std::make_unique<LiggghtsBackend>(study, options);
}

namespace {

// The backend behind `backend` if this factory made it; `caller` names the function in the error.
LiggghtsBackend& liggghtsBackend(adapter::CouplingApi& backend, const char* caller) {
  auto* liggghts = dynamic_cast<LiggghtsBackend*>(&backend);
  if (!liggghts) throw CouplingError(ErrorCode::BadRequest, std::string(caller) + ": not a liggghts backend");
  return *liggghts;
}

}  // namespace

std::array<double, 3> meshTotalForce(adapter::CouplingApi& backend, const std::string& geometry) {
  return liggghtsBackend(backend, "meshTotalForce").meshTotalForce(geometry);
}

std::int64_t particleCount(adapter::CouplingApi& backend) {
  return liggghtsBackend(backend, "particleCount").particleCount();
}

SoilOrigin soilOrigin(adapter::CouplingApi& backend) { return liggghtsBackend(backend, "soilOrigin").soilOrigin(); }

std::vector<std::array<double, 4>> particles(adapter::CouplingApi& backend) {
  return liggghtsBackend(backend, "particles").particles();
}

adapter::SettledSoil depositSoil(const study::Study& study) {
  ensureMpi();
  const auto work_dir = std::filesystem::temp_directory_path() / uniqueWorkDirectoryName(worldRank());
  std::filesystem::create_directories(work_dir);
  struct Cleanup {
    std::filesystem::path dir;
    ~Cleanup() {
      std::error_code ignored;
      std::filesystem::remove_all(dir, ignored);
    }
  } cleanup{work_dir};
  return depositInInstance(study, translateStudy(study, work_dir), work_dir);
}

bool isLeaderRank() {
  ensureMpi();
  return worldRank() == 0;
}

void followLeader(const study::Study& study) { followLeader(study, {}); }

void followLeader(const study::Study& study, const BackendOptions& options) {
  ensureMpi();
  Engine engine(study, options);
  while (true) {
    OpHeader header;
    std::vector<double> payload;
    broadcast(header, payload);
    if (header.op == Op::Shutdown) return;
    execute(engine, header, payload);
  }
}

}  // namespace demfem::liggghts

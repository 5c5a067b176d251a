// The engine's set-up (engine.hpp): the tools, the settled soil (read, deposited or given) or the
// probe spheres, the tool meshes and the per-step force hook.
#include "engine.hpp"

#include <mpi.h>

#include <atom.h>
#include <fix_external.h>
#include <fix_mesh_surface.h>
#include <lammps.h>
#include <modify.h>
#include <tri_mesh.h>
#include <update.h>

#include <algorithm>
#include <limits>
#include <map>

namespace demfem::liggghts::detail {

using adapter::CouplingError;
using adapter::ErrorCode;

namespace {

// Throws BadRequest naming the first sphere whose material is not a particle material of the study
// or whose radius is not positive; `what` names the kind of sphere.
void checkSpheres(const study::Study& study, const std::vector<Sphere>& spheres, const std::string& what) {
  for (const auto& sphere : spheres) {
    if (!std::any_of(study.soil.layers.begin(), study.soil.layers.end(),
                     [&sphere](const study::Layer& l) { return l.material == sphere.material; }))
      throw CouplingError(ErrorCode::BadRequest, what + " material \"" + sphere.material +
                                                     "\" is not a particle material of the study");
    if (!(sphere.radius_m > 0)) throw CouplingError(ErrorCode::BadRequest, what + " radius must be positive");
  }
}

SettledParticles givenSoil(const study::Study& study, const std::vector<Sphere>& spheres) {
  SettledParticles particles;
  for (const auto& p : spheres)
    particles.insert(particles.end(), {p.centre_m[0], p.centre_m[1], p.centre_m[2], p.radius_m,
                                       static_cast<double>(atomType(study, p.material))});
  return particles;
}

// Rank 0's particles broadcast to every rank. Collective.
SettledParticles broadcastParticles(SettledParticles particles) {
  auto count = static_cast<std::uint64_t>(particles.size());
  MPI_Bcast(&count, 1, MPI_UINT64_T, 0, MPI_COMM_WORLD);
  particles.resize(count);
  MPI_Bcast(particles.data(), static_cast<int>(count), MPI_DOUBLE, 0, MPI_COMM_WORLD);
  return particles;
}

// Rank 0's verdict broadcast; when it is a failure every rank throws `code` (rank 0 with `problem`,
// the others with `elsewhere`), so that no rank waits forever. Collective.
void agreeOnFailure(int ok, ErrorCode code, const std::string& problem, const std::string& elsewhere) {
  MPI_Bcast(&ok, 1, MPI_INT, 0, MPI_COMM_WORLD);
  if (!ok) throw CouplingError(code, worldRank() == 0 ? problem : elsewhere);
}

}  // namespace

Engine::Engine(const study::Study& study, const BackendOptions& options)
    : work_dir_(std::filesystem::temp_directory_path() / uniqueWorkDirectoryName(worldRank())) {
  std::filesystem::create_directories(work_dir_);
  try {
    build(study, options);
  } catch (...) {
    release();
    throw;
  }
}

Engine::~Engine() { release(); }

void Engine::build(const study::Study& study, const BackendOptions& options) {
  const InputDeck deck = translateStudy(study, work_dir_);  // throws before LIGGGHTS sees anything
  dt_ = deck.time_step_s;
  addTools(study);
  checkSpheres(study, options.probes, "probe sphere");
  checkSpheres(study, options.settled_soil, "settled-soil particle");
  if (options.probes.empty()) placeSoil(study, deck, options);
  else placeProbes(study, deck, options);
  for (const auto& line : deck.tools) command(line);
  start_step_ = lmp_->update->ntimestep;
  for (std::size_t g = 0; g < tools_.size(); ++g) findMesh(g);
  installForceHook();
  // Set-up without a step: distributes the meshes over the ranks (before it every rank holds all).
  command("run 0 post no");
  for (std::size_t g = 0; g < tools_.size(); ++g) checkMesh(g);
  mesh_edited_ = false;
}

// The tools' keypoint surfaces at their start positions, written as STL files for the deck.
void Engine::addTools(const study::Study& study) {
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
}

// The settled soil is read from its file or deposited in an instance of its own, so that the
// simulation starts from the same state either way (positions only, at rest); then the tools'
// space is cleared.
void Engine::placeSoil(const study::Study& study, const InputDeck& deck, const BackendOptions& options) {
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
}

// Fixed probe spheres instead of the soil (no time integration of particles).
void Engine::placeProbes(const study::Study& study, const InputDeck& deck, const BackendOptions& options) {
  openMainInstance(deck);
  for (const auto& probe : options.probes)
    addSphere(atomType(study, probe.material), probe.centre_m, probe.radius_m, study.material(probe.material).density_kg_m3);
}

// The per-step hook: fix external calls afterForces() in post_force, after the tool wall (defined
// earlier) has stored this step's contact forces.
void Engine::installForceHook() {
  command("fix demfem_node_forces all external pf/callback 1 1");
  auto* hook = dynamic_cast<LAMMPS_NS::FixExternal*>(lmp_->modify->find_fix_id("demfem_node_forces"));
  if (!hook) throw CouplingError(ErrorCode::Internal, "LIGGGHTS did not create the node-force hook (fix external)");
  hook->set_callback(&Engine::afterForces, this);
}

void Engine::openMainInstance(const InputDeck& deck) {
  instance_ = std::make_unique<Instance>(work_dir_, "main");
  lmp_ = instance_->get();
  for (const auto& line : deck.setup) command(line);
}

// Adds a sphere at rest (bin frame, m; kg/m^3). LIGGGHTS numbers the atoms 1, 2, ... in creation order.
void Engine::addSphere(int type, const Vec3& centre, double radius, double density) {
  command("create_atoms " + std::to_string(type) + " single " + exact(centre[0]) + " " + exact(centre[1]) + " " +
          exact(centre[2]) + " units box");
  command("set atom " + std::to_string(lmp_->atom->natoms) + " diameter " + exact(2 * radius) + " density " +
          exact(density));
}

// The settled soil of the study: read from adapter::settledSoilFile() in soilDirectory() (rank 0
// reads and broadcasts), or, when the file is missing and the study deposits with LIGGGHTS,
// deposited in an instance of its own and written there (rank 0 writes).
SettledParticles Engine::settledSoil(const study::Study& study, const InputDeck& deck, const BackendOptions& options) {
  soil_file_ = adapter::settledSoilFile(study, soilDirectory(options));
  const adapter::SettledSoil soil = readOrDepositSoil(study, deck);
  SettledParticles particles;
  if (worldRank() == 0) {
    soil_record_ = adapter::soilRecordJson(soil, soil_file_, adapter::settledSoilChecksum(soil_file_));
    particles = fromNeutral(study, soil);
  }
  return broadcastParticles(std::move(particles));
}

// Rank 0 reads the soil file; every rank takes the branch rank 0's status names (on rank 0 only
// the returned soil is filled).
adapter::SettledSoil Engine::readOrDepositSoil(const study::Study& study, const InputDeck& deck) {
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
  if (soil_deposited_) depositAndWriteSoil(study, deck, soil);
  return soil;
}

// Deposits the soil (a study that deposits with LIGGGHTS only) and writes the soil file (rank 0).
void Engine::depositAndWriteSoil(const study::Study& study, const InputDeck& deck, adapter::SettledSoil& soil) {
  if (study.soil.deposition_backend != capabilities().name)
    throw CouplingError(ErrorCode::BadRequest, "liggghts backend: no settled soil " + soil_file_.string() +
                                                   "; the study deposits it with " + study.soil.deposition_backend +
                                                   " (/soil/deposition/backend): run `demfem deposit` on the study first");
  soil = depositInInstance(study, deck, work_dir_);
  int written = 1;
  std::string problem;
  if (worldRank() == 0) try {
      adapter::writeSettledSoil(soil_file_, soil);
    } catch (const std::exception& e) {
      written = 0;
      problem = e.what();
    }
  agreeOnFailure(written, ErrorCode::Internal, problem, "rank 0 cannot write " + soil_file_.string());
}

// Checks that the distributed mesh holds the keypoint triangles, each once, and finds the id offset.
void Engine::checkMesh(std::size_t g) {
  auto& tool = tools_[g];
  LAMMPS_NS::TriMesh* mesh = tool.mesh_fix->triMesh();
  int lowest = std::numeric_limits<int>::max();
  long long owned = mesh->sizeLocal();
  for (int i = 0; i < mesh->sizeLocal(); ++i) lowest = std::min(lowest, mesh->id(i));
  MPI_Allreduce(MPI_IN_PLACE, &lowest, 1, MPI_INT, MPI_MIN, MPI_COMM_WORLD);
  MPI_Allreduce(MPI_IN_PLACE, &owned, 1, MPI_LONG_LONG, MPI_SUM, MPI_COMM_WORLD);
  tool.id_offset = lowest;
  if (owned != static_cast<long long>(tool.surface.triangles.size()))
    throw CouplingError(ErrorCode::Internal, "LIGGGHTS mesh of tool \"" + tool.name + "\" has " + std::to_string(owned) +
                                                 " triangles over all ranks, the keypoint surface " +
                                                 std::to_string(tool.surface.triangles.size()));
  const int all = mesh->sizeLocal() + mesh->sizeGhost();
  for (int i = 0; i < all; ++i) copyKeypoints(tool, i);  // throws on a mismatch
}

}  // namespace demfem::liggghts::detail

// Private to the LIGGGHTS backend: the MPI session, one LIGGGHTS instance, and the settled-soil
// exchange with the backend-neutral soil file (adapter/settled_soil.hpp), shared by the engine
// (engine.hpp), the leader/follower broadcast (leader_follower.hpp) and the facade (backend.cpp). No LIGGGHTS or MPI header here: their types
// appear only as forward declarations, the code that uses them is in mpi_session.cpp, instance.cpp
// and soil_file.cpp (docs/liggghts-backend.md).
#pragma once

#include "demfem/adapter/settled_soil.hpp"
#include "demfem/backends/liggghts/backend.hpp"
#include "demfem/backends/liggghts/input_deck.hpp"

#include <cstddef>
#include <filesystem>
#include <string>
#include <vector>

namespace LAMMPS_NS {
class LAMMPS;
}

namespace demfem::liggghts::detail {

// --- MPI session (mpi_session.cpp) ---
// Initialises MPI once per process (singleton when not under mpirun); finalised at exit.
void ensureMpi();
int worldRank();
int worldSize();

// --- one LIGGGHTS instance (instance.cpp) ---
// A number in a LIGGGHTS command, without loss (std::to_string keeps 6 decimals only).
std::string exact(double value);

// One LIGGGHTS instance on MPI_COMM_WORLD; its screen and log go to `<name>-screen.txt` and
// `<name>.log` in the work directory, never to our stdout (`-screen none` makes LIGGGHTS 3.8 crash
// when it reads an STL file). Collective construction.
class Instance {
 public:
  Instance(const std::filesystem::path& work_dir, const std::string& name);
  ~Instance();
  Instance(const Instance&) = delete;
  Instance& operator=(const Instance&) = delete;

  LAMMPS_NS::LAMMPS* get() const { return lmp_; }
  // Runs one input command; if LIGGGHTS exits on it, an exit handler names it and LIGGGHTS' message.
  void command(const std::string& line);
  double computeScalar(const char* id);

 private:
  std::filesystem::path screen_;
  LAMMPS_NS::LAMMPS* lmp_ = nullptr;
};

// --- settled soil (soil_file.cpp) ---
// The settled soil (before the tools clear their space): x, y, z, radius (m) and atom type per
// particle, kParticleValues doubles each, in the order of their LIGGGHTS ids at the end of the
// deposition. Every rank holds all of it.
constexpr std::size_t kParticleValues = 5;
using SettledParticles = std::vector<double>;

// All particles of an instance, gathered on every rank and ordered by LIGGGHTS id. Collective.
SettledParticles gatherParticles(LAMMPS_NS::LAMMPS* lmp);

// Rank 0's status of reading the soil file, broadcast so that every rank takes the same branch.
enum class SoilFileStatus : int { Missing = 0, Loaded = 1, Damaged = 2 };

std::filesystem::path soilDirectory(const BackendOptions& options);
adapter::SettledSoil toNeutral(const study::Study& study, const SettledParticles& particles);
SettledParticles fromNeutral(const study::Study& study, const adapter::SettledSoil& soil);

// Deposits the study's soil in an instance of its own (deck.deposition, then deck.trim) and returns
// it settled (see soil_file.cpp for the criterion). Collective.
adapter::SettledSoil depositInInstance(const study::Study& study, const InputDeck& deck,
                                       const std::filesystem::path& work_dir);

}  // namespace demfem::liggghts::detail

// The built-in DEM engine (docs/architecture.md section 5): spheres, plane walls and triangle-mesh walls,
// velocity-Verlet integration, linked cells + Verlet lists with a skin, a thread team (thread_team.hpp).
//
// Contract
// - SI units, bin frame (x across, y up, z along the bin; docs/architecture.md section 10). Gravity along -y
//   unless set otherwise.
// - Data layout (for speed): particle quantities are separate contiguous arrays (structure of
//   arrays; vectors stored xyz-interleaved); the half neighbour list is CSR (row = particle i, j > i,
//   sorted), and each list slot owns its contact history and its pair stiffness, so the pair loop
//   touches flat arrays only. Contact models are template parameters of the pair loop (no virtual
//   call, no allocation per contact). Lists are rebuilt when any particle or mesh node has moved more
//   than skin/2 since the last build; contact history is carried over by (i, j) (pairs) and by
//   (particle, wall, feature) (walls, with the history handed on when a contact slides from one
//   feature of a mesh to the next).
// - Determinism: with the same inputs and thread count, results are bit-identical. The particles
//   are split into as many parts as threads (a static partition); each part sums pair forces into
//   its own buffer and the buffers are added in part order, whichever thread ran each part. Wall
//   contacts are gathered in particle order.
// - Threads: each simulation owns its team of `threads` threads (a copy gets its own); a step is a
//   few phases of the team, each running every part once on whichever threads have a core
//   (docs/builtin-dem.md, "Threads on a shared machine"). A simulation is used by one caller at a
//   time.
// - Time step: setTimeStep() refuses a step above the stability limit of the stiffest spring
//   (2 sqrt(m*/k_max), explicit central-difference limit of an undamped oscillator).
// - Failure: run() throws BlowUp naming the particle, the step and what went wrong (NaN, overlap
//   beyond overlapLimitFraction() * the smaller radius, centre outside the domain); the simulation
//   is then left at the failing step (the caller keeps its last checkpoint).
// - Mesh walls: positions are given in each mesh's local frame; the mesh moves rigidly with its
//   RigidMotion-style translation and deforms through setNodePositions(). Forces on mesh nodes are
//   the reactions of the particle contacts, split by barycentric weights (force and moment conserved).
#pragma once

#include "demfem/adapter/checkpoint_file.hpp"
#include "demfem/backends/builtin/contact_law.hpp"
#include "demfem/backends/builtin/thread_team.hpp"
#include "demfem/backends/builtin/triangle_mesh.hpp"
#include "demfem/study/study.hpp"

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <iosfwd>
#include <memory>
#include <new>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace demfem::builtin {

class BlowUp : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Materials and the interaction table of a soil, resolved to indices and PairLaw coefficients.
struct MaterialTable {
  std::vector<study::DemMaterial> materials;
  std::vector<PairLaw> laws;  // materials.size()^2, symmetric
  int index(const std::string& name) const;  // throws std::invalid_argument naming the material
  const PairLaw& law(int a, int b) const { return laws[static_cast<std::size_t>(a) * materials.size() + b]; }
  // Pairs without an Interaction stay undefined (wall-wall pairs need none; the simulation refuses a
  // particle or wall whose pairs with the materials in use are missing). Throws
  // std::invalid_argument for a restitution outside (0, 1].
  static MaterialTable fromSoil(const study::Soil& soil);
};

struct PlaneWall {
  Vec3 point{0, 0, 0};
  Vec3 normal{0, 1, 0};  // unit, pointing into the particle side
  int material = 0;
  std::int32_t padding = 0;  // named: a checkpoint holds the struct's bytes, none of them undefined
  // Signed distance (m) of the point x[0..2] from the plane, positive on the particle side.
  double distance(const double* x) const {
    return (x[0] - point[0]) * normal[0] + (x[1] - point[1]) * normal[1] + (x[2] - point[2]) * normal[2];
  }
};

struct Domain {
  Vec3 lo{0, 0, 0}, hi{0, 0, 0};  // a particle centre outside is a blow-up
};

struct ParticleState {
  Vec3 x, v{0, 0, 0}, w{0, 0, 0};
  double radius = 0;
  int material = 0;
  int layer = 0;
};

struct WallTouch;  // a wall feature a particle touches (wall_forces.cpp)

// The pair loop's touching contacts of a batch of rows as arrays, memory reused (pair_forces.cpp):
// list slot, particles i (the row) and j, index of their PairLaw; centre difference x_i - x_j by
// component, distance, its inverse, cohesive force; the law's results (force on i, torques on i and
// j, overlap, the history by its stored offset).
struct PairBatch {
  std::vector<std::int32_t> slot, i, j, law;
  std::vector<double> d[3], r, rinv, cohesion, delta;
  std::vector<double> f[3], ti[3], tj[3], hist[HistoryLayout::kMaxSize];
  void growTo(std::size_t slots);  // every array at least `slots` long (never shrinks)
};

// The wall loop's contacts of a run of particles as arrays, memory reused (wall_forces.cpp):
// particle, index of its PairLaw (particle material, wall material), stiffness; unit normal
// towards the particle, centre-to-wall distance, the wall's velocity at the contact point,
// cohesive force; the law's results (force and torque on the particle, overlap, the history by its
// stored offset).
struct WallBatch {
  std::vector<std::int32_t> i, law;
  std::vector<ContactStiffness> stiffness;
  std::vector<double> n[3], dist, vwall[3], cohesion, delta;
  std::vector<double> f[3], t[3], hist[HistoryLayout::kMaxSize];
  void growTo(std::size_t contacts);  // every array at least `contacts` long (never shrinks)
};

// An allocator that leaves an element appended without a value uninitialised (default
// initialisation) instead of clearing it first, for vectors whose every element is then written
// field by field: the wall loop's contact lists, one element per wall contact and step, where the
// clearing (a string store) held up the loads after it (docs/builtin-dem.md, "The wall loop's
// stores").
template <class T>
class DefaultInitAllocator : public std::allocator<T> {
 public:
  template <class U>
  struct rebind {
    using other = DefaultInitAllocator<U>;
  };
  DefaultInitAllocator() = default;
  template <class U>
  DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}
  template <class U>
  void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) {
    ::new (static_cast<void*>(p)) U;
  }
  template <class U, class... Args>
  void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};

class DemSimulation {
 public:
  DemSimulation(const study::Soil& soil, const Domain& domain, int threads);

  const MaterialTable& materials() const { return table_; }
  const study::ContactModel& contactModel() const { return model_; }

  // --- setup ---
  int addParticle(const ParticleState& p);
  // Keeps only particles with keep[i] != 0 (order preserved); contact history is dropped.
  void keepParticles(const std::vector<char>& keep);
  void setParticleMaterial(int i, int material, int layer);
  int addPlane(const PlaneWall& wall);
  int addMesh(TriangleMesh mesh);
  void setGravity(const Vec3& g) { gravity_ = g; }
  const Vec3& gravity() const { return gravity_; }
  // Deposition only (docs/builtin-dem.md, "Deposition"): a background damping force -c m v and
  // torque -c I w on every particle, c in 1/s (0 = none, the study's physics). It removes the
  // elastic ringing that the hysteretic spring and the sticking tangential spring never dissipate,
  // so that a pack comes to rest; it is not part of the saved state, and saveState() refuses a
  // simulation with it on.
  void setSettlingDamping(double rate_per_s);
  double settlingDamping() const { return damping_per_s_; }
  // Sets the step; throws std::invalid_argument if dt <= 0 or above the stability limit.
  void setTimeStep(double dt);
  double timeStep() const { return dt_; }
  // The step whose spin scale the edem-standard rolling law keeps at every shorter DEM step
  // (contact_law.hpp, rollingSpinScale; a study's is physics::rollingRegularisationStep). 0, the
  // default: the scale follows the DEM step. Throws std::invalid_argument if negative.
  void setRollingRegularisationStep(double step_s);
  double rollingStep() const { return std::max(dt_, rolling_step_s_); }
  // 2 sqrt(m*/k_max) over the particles and walls in it: the largest step setTimeStep accepts (the
  // study's step is chosen by physics::demTimeStep, backends/physics/time_step.hpp).
  double stabilityLimit() const;
  static constexpr double overlapLimitFraction() { return 0.5; }

  // --- meshes ---
  int meshCount() const { return static_cast<int>(meshes_.size()); }
  const TriangleMesh& mesh(int m) const { return meshes_[m]; }
  // Rigid translation of mesh m (bin frame): x_bin = origin + x_local + velocity (t - t0).
  void setMeshMotion(int m, const Vec3& origin, const Vec3& velocity, double t0);
  // New local node positions (deformation); the node velocity used for contact damping is the change
  // divided by `interval_s` (the time since the previous call; 0 = no velocity).
  void setNodePositions(int m, const std::vector<Vec3>& local, double interval_s);
  // Force the particles exert on each node (N, bin frame = local axes): at the last step, and the
  // impulse accumulated since resetNodeImpulse() (N s).
  const std::vector<double>& nodeForces(int m) const { return mesh_force_[m]; }
  const std::vector<double>& nodeImpulse(int m) const { return mesh_impulse_[m]; }
  void resetNodeImpulse();
  Vec3 planeForce(int plane) const { return plane_force_[plane]; }  // on the wall, last step

  // --- running ---
  void run(long steps);
  double time() const { return time_; }
  long stepCount() const { return step_; }

  // --- state ---
  std::size_t particleCount() const { return radius_.size(); }
  ParticleState particle(std::size_t i) const;
  double kineticEnergy() const;
  Vec3 momentum() const;
  Vec3 angularMomentum() const;  // about the origin, incl. spins
  double maxOverlap() const;     // largest pair or wall overlap at the last step (m)
  std::size_t contactCount() const;  // touching pair + wall contacts at the last step
  std::size_t bytesPerParticle() const;  // memory of all per-particle and per-contact arrays / N
  // Phases of its thread team so far (none with 1 thread), and those its calling thread ran alone
  // (ThreadTeam, "Team or caller alone"). A copy's team starts from none.
  long teamPhases() const { return team_.phases(); }
  long teamPhasesAlone() const { return team_.phasesAlone(); }

  // Bit-exact state (particles, lists, histories, meshes, time). A restored simulation continues
  // bit-identically. withState() returns this simulation with the saved state; it requires the
  // same set-up (soil, threads, particles, walls, meshes; what the study fixes must be equal) and
  // checks what evolves (finite, sized to the particles, indices in range), throwing
  // adapter::CouplingError(BadRequest) naming the first inconsistency; *this is never changed.
  // loadState() is the same with the strong guarantee: on a throw the state is as it was.
  void saveState(adapter::PayloadWriter& out) const;
  DemSimulation withState(adapter::PayloadReader& in) const;
  void loadState(adapter::PayloadReader& in);

  // The particles for ParaView as a .vtp (vtkio: binary, compressed, with the simulated time): radius_m,
  // velocity_m_s, layer and force_N (the contact force of the last step, gravity excluded). Written
  // atomically; throws adapter::OutputError (adapter/output_files.hpp) naming the file.
  void writeParticlesVtk(const std::filesystem::path& file) const;
  // Mesh m in the bin frame as a .vtp: its triangles, node displacement_m (deformation, local axes) and
  // node force_N (the particles' force of the last step; positions as doubles). Same.
  void writeMeshVtk(int m, const std::filesystem::path& file) const;

 private:
  struct WallContact {
    std::int32_t particle, wall;    // wall: plane index, or planes.size() + mesh index
    std::int64_t key;               // feature key (0 for a plane)
    double hist[HistoryLayout::kMaxSize];
    ContactStiffness stiffness;     // fixed for the particle-wall pair: computed when the contact opens
    std::int32_t nodes[3];
    std::int32_t padding;           // named: a checkpoint holds the struct's bytes (zero)
    double weights[3];
    double force[3];                // on the particle
  };

  using WallContacts = std::vector<WallContact, DefaultInitAllocator<WallContact>>;

  struct MeshShare {
    std::int32_t mesh, node;
    double force[3];  // on the node
  };

  // What one part (partition of the particles) keeps from step to step (memory reused) and reports
  // to the step; whichever thread runs the part uses it.
  struct PartState {
    std::vector<double> f, t;            // pair force buffers (more than one part)
    // The wall contacts of its particles at the last force evaluation, in particle order, with
    // their CSR offsets over the part's particles (empty before the first). The wall loop builds
    // the next ones in wall_next / wall_start_next from these and swaps: a part's contacts stay
    // with the thread that ran it, never gathered into one array (docs/builtin-dem.md).
    WallContacts wall, wall_next;
    std::vector<std::int32_t> wall_start, wall_start_next;
    std::vector<std::int32_t> rows;      // list build: the neighbours of its rows
    PairBatch batch;                     // pair loop: the touching contacts of a batch of rows
    WallBatch wall_batch;                // wall loop: the contacts of a run of particles
    // Its wall contacts' reactions at the last force evaluation, kept by the wall loop: their sum
    // on each plane, and each mesh contact's share of each of its nodes, in contact order
    // (scatterWallForces adds the parts' in part order).
    std::vector<Vec3> plane_force;
    std::vector<MeshShare> mesh_shares;
    double pair_max = 0, wall_max = 0;   // largest overlap of its pair and of its wall contacts
    std::int64_t pair_bad = -1, wall_bad = -1, kick_bad = -1;  // first failing particle, -1 none
    int wall_bad_wall = -1;              // the wall (planes, then meshes) of wall_bad's overlap
    bool moved = false;                  // a particle moved beyond skin/2 since the last build
  };

  // Linked cells of edge >= 2 R_max + skin over the particles' bounding box: counting-sorted
  // particle ids per cell (neighbour_lists.cpp).
  struct CellGrid {
    Vec3 lo{0, 0, 0};
    double size = 0;
    int n[3] = {1, 1, 1};
    std::vector<std::int32_t> start, items;
    int cellOf(double c, int axis) const;
    std::size_t index(int i, int j, int k) const { return (static_cast<std::size_t>(k) * n[1] + j) * n[0] + i; }
  };

  // Particles [lo, hi) of part `part` (the static partition every loop uses).
  std::size_t rangeBegin(int part) const { return particleCount() * part / threads_; }
  std::size_t rangeEnd(int part) const { return particleCount() * (part + 1) / threads_; }

  // simulation.cpp: the step is a sequence of phases of the team, each run once per part, with the
  // serial work between them on the calling thread. With drift_ahead (a step of run() followed by
  // another), each part whose step succeeded also does the next step's first half kick and drift
  // in the step's last phase, and that step skips its drift phase (drifted_).
  void step(bool drift_ahead);
  void drift(int part);  // half kick, drift, skin check, force reset
  void kick(int part);   // half kick, health check
  // Pair and wall forces added to f_, t_, then with then_kick the second half kick and with
  // then_drift the next step's drift of every part without a failure; failures recorded.
  void contactForces(bool then_kick, bool then_drift);
  void raiseFailure() const;  // throws BlowUp for the first failure the parts recorded
  void resetFailures();
  // neighbour_lists.cpp: linked cells, the half pair list, the wall candidates (broad search)
  void rebuildLists();
  void buildCellGrid();
  void buildRows(int part);
  void sizeNextLists();
  void fillNextList(int part);
  void buildWallCandidates(const CellGrid& grid);
  bool meshesMovedBeyondSkin() const;
  void updateMeshBinNodes();
  // pair_forces.cpp and wall_forces.cpp: each a loop per contact model (template arguments)
  void pairForces(int part);
  template <study::NormalModel N, study::RollingModel R, bool Shear> void pairLoop(int part);
  template <int H> std::size_t findTouching(std::size_t i0, std::size_t i1, std::size_t window_end, PairBatch& b);
  template <int H>
  double scatterBatch(std::size_t i0, std::size_t i1, std::size_t count, std::size_t hi, const PairBatch& b, double* F,
                      double* Tq, double* Fpast, double* Tpast);
  std::int64_t firstOverlapFailure(std::size_t count, const PairBatch& b) const;
  void sumPairForces(int part);
  void wallForces(int part);
  template <study::NormalModel N, study::RollingModel R, bool Shear> void wallLoop(int part);
  // The contacts of particle i at batch places count, count + 1, ... (their WallContacts appended
  // to out; old: its n_old contacts of the last step); each returns the new count.
  std::size_t queueWallContacts(std::size_t i, const WallContact* old, int n_old, WallContacts& out, WallBatch& b,
                                std::size_t count) const;
  std::size_t queuePlaneContacts(std::size_t i, const WallContact* old, int n_old, WallContacts& out,
                                 WallBatch& b, std::size_t count) const;
  void queueWallContact(std::size_t i, int wall, const ContactStiffness& stiffness, const double* hist, const Vec3& normal,
                        double dist, const Vec3& vwall, WallBatch& b, std::size_t k) const;
  // The law of a wall batch's `count` contacts, whose WallContacts are contacts[0, count): forces to
  // the particles and into the contacts, histories into the contacts, the part's overlap checks.
  template <study::NormalModel N, study::RollingModel R, bool Shear>
  void wallBatchForces(PartState& part, std::size_t count, WallContact* contacts, double& max_overlap);
  int planeTouches(std::size_t i, WallTouch* touch, int count) const;  // fine search: appends, returns the count
  int meshTouches(std::size_t i, WallTouch* touch, int count) const;
  // old: the particle's n_old contacts of the last step; matched_old[a] indexes them, -1 none.
  static void matchHistory(const WallContact* old, int n_old, const WallTouch* touch, int count, const bool* accepted,
                           int* matched_old);
  WallContact openWallContact(std::size_t i, const WallTouch& touch, const WallContact* matched_old) const;
  Vec3 wallVelocity(const WallTouch& touch) const;
  int wallMaterial(int wall) const;
  // The wall contacts of all particles in particle order with CSR offsets over the particles (offsets
  // empty before the first force evaluation): a checkpoint's form of the parts' lists.
  struct WallContactList {
    std::vector<WallContact> contacts;
    std::vector<std::int32_t> start;
  };
  WallContactList wallContactList() const;
  void setWallContacts(const WallContactList& list);  // into the parts' lists (checkpoint.cpp)
  void dropWallContacts();  // no wall contact history: the particles changed
  // A contact's reaction on its wall (force: on the particle) into the part's sums.
  void keepWallReaction(PartState& part, const WallContact& wc, const double* force) const;
  // The reactions on the planes and mesh nodes: the parts' sums, added in part order (serial).
  void scatterWallForces();
  // Gravity (and settling damping) only: the start of every force evaluation. A copy of what it
  // reads, so that a loop storing forces need not reload it for every particle.
  struct ForceReset {
    const double *mass, *v, *w, *inv_inertia;
    Vec3 gravity;
    double damping_per_s;
    bool damped() const { return damping_per_s > 0; }
    // With the damping's branch taken out of the loop (Damped == damped()): a loop without
    // control flow vectorises.
    template <bool Damped>
    [[gnu::always_inline]] void apply(std::size_t i, double* f, double* t) const {
      for (int c = 0; c < 3; ++c) {
        f[3 * i + c] = mass[i] * gravity[c];
        t[3 * i + c] = 0;
      }
      if constexpr (Damped)
        for (int c = 0; c < 3; ++c) {
          f[3 * i + c] -= damping_per_s * mass[i] * v[3 * i + c];
          t[3 * i + c] -= damping_per_s * w[3 * i + c] / inv_inertia[i];
        }
    }
    void operator()(std::size_t i, double* f, double* t) const {
      if (damped())
        apply<true>(i, f, t);
      else
        apply<false>(i, f, t);
    }
  };
  ForceReset forceReset() const {
    return {mass_.data(), v_.data(), w_.data(), inv_inertia_.data(), gravity_, damping_per_s_};
  }
  // The per-particle steps of the Verlet sweeps (simulation.cpp), on a copy of the array pointers
  // for the same reason as ForceReset.
  struct VerletSweep {
    double half, dt;
    double *x, *v, *w, *f, *t;
    const double *x_build, *inv_mass, *inv_inertia;
    Domain domain;
    [[gnu::always_inline]] void halfKick(std::size_t i) const {
      for (int c = 0; c < 3; ++c) {
        v[3 * i + c] += half * f[3 * i + c] * inv_mass[i];
        w[3 * i + c] += half * t[3 * i + c] * inv_inertia[i];
      }
    }
    // x += dt v; returns the squared distance from the position at the last list build.
    [[gnu::always_inline]] double move(std::size_t i) const {
      double d2 = 0;
      for (int c = 0; c < 3; ++c) {
        x[3 * i + c] += dt * v[3 * i + c];
        const double d = x[3 * i + c] - x_build[3 * i + c];
        d2 += d * d;
      }
      return d2;
    }
    // Finite and inside the domain (the health check after the second half kick), without branches.
    [[gnu::always_inline]] bool healthy(std::size_t i) const {
      bool ok = true;
      for (int c = 0; c < 3; ++c) {
        const double xc = x[3 * i + c];
        ok &= std::isfinite(xc) & std::isfinite(v[3 * i + c]) & std::isfinite(w[3 * i + c]);
        ok &= (xc >= domain.lo[c]) & (xc <= domain.hi[c]);
      }
      return ok;
    }
  };
  VerletSweep verletSweep() {
    return {0.5 * dt_, dt_, x_.data(), v_.data(), w_.data(), f_.data(), t_.data(), x_build_.data(), inv_mass_.data(),
            inv_inertia_.data(), domain_};
  }
  ContactStiffness wallStiffness(int i, int wall_material) const;
  // Marks a material as used by particles or walls; throws if a pair it meets has no interaction.
  void useMaterial(int material, bool particle);
  [[noreturn]] void fail(std::size_t particle, const std::string& what) const;
  std::string wallOverlapCause(std::int64_t particle) const;  // the message of a wall overlap failure
  void checkRestoredAgainst(const DemSimulation& live, const WallContactList& wall,
                            const adapter::PayloadReader& in) const;

  MaterialTable table_;
  study::ContactModel model_;
  HistoryLayout layout_;
  Domain domain_;
  int threads_;
  Vec3 gravity_{0, -9.81, 0};
  double damping_per_s_ = 0;
  double dt_ = 0, time_ = 0, rolling_step_s_ = 0;
  long step_ = 0;
  double skin_ = 0;
  double list_min_radius_ = 0;  // the smallest radius at the last list build (overlap check, pair_forces.cpp)
  bool lists_valid_ = false;
  bool drifted_ = false;  // the last step drifted the particles for this one (false between runs)

  // particles (SoA; vectors xyz-interleaved)
  std::vector<double> x_, v_, w_, f_, t_, x_build_;
  std::vector<double> radius_, mass_, inv_mass_, inv_inertia_;
  std::vector<std::int32_t> material_, layer_;
  std::vector<std::uint8_t> used_;  // per material: 1 wall, 2 particle

  // half neighbour list (CSR) with per-slot stiffness and history; nb_i_ holds each slot's row
  // (derived from nb_start_, not saved): the pair loop runs over slots, not rows
  std::vector<std::int32_t> nb_start_, nb_j_, nb_i_;
  std::vector<ContactStiffness> nb_stiff_;
  std::vector<double> nb_hist_;
  std::vector<std::uint8_t> nb_touch_;

  // walls
  std::vector<PlaneWall> planes_;
  std::vector<TriangleMesh> meshes_;
  std::vector<std::vector<Vec3>> mesh_bin_nodes_;    // current bin positions
  std::vector<std::vector<Vec3>> mesh_build_nodes_;  // bin positions at the last list build
  std::vector<std::int32_t> wc_start_;               // candidate (mesh, triangle) per particle (CSR)
  std::vector<std::int32_t> wc_mesh_, wc_tri_;
  std::vector<std::uint8_t> near_plane_;             // per particle: within reach of a plane wall
  std::vector<std::vector<double>> mesh_force_, mesh_impulse_;
  std::vector<Vec3> plane_force_;

  std::vector<std::size_t> part_window_end_;  // one past the highest particle a part's rows reach
  // blow-up detection filled by the force loops
  double max_overlap_ = 0;

  // the team and what its parts share within a step
  ThreadTeam team_;
  std::vector<PartState> part_;
  CellGrid grid_;
  std::vector<std::int32_t> build_start_, build_j_, build_i_;  // the list being built (rebuildLists)
  std::vector<ContactStiffness> next_stiff_;
  std::vector<double> next_hist_;
  std::vector<std::uint8_t> next_touch_;
};

}  // namespace demfem::builtin

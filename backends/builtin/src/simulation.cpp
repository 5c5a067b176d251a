// The built-in DEM engine: set-up of particles and walls, the velocity-Verlet step and the state
// queries. Materials and time step, neighbour lists, pair and wall forces, checkpoints and VTK
// output live in their own files of this folder; the threads in thread_team.hpp.
#include "demfem/backends/builtin/simulation.hpp"

#include "vectorised_loop.hpp"
#include "demfem/backends/physics/dem_assert.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <sstream>

namespace demfem::builtin {

namespace {
constexpr double kPi = std::numbers::pi;
}  // namespace

using detail::norm2;

// ---------------------------------------------------------------- construction

DemSimulation::DemSimulation(const study::Soil& soil, const Domain& domain, int threads)
    : table_(MaterialTable::fromSoil(soil)),
      model_(soil.contact),
      layout_(HistoryLayout::of(soil.contact)),
      domain_(domain),
      threads_(std::max(1, threads)),
      team_(threads_, threads_),
      part_(threads_) {
  used_.assign(table_.materials.size(), 0);
  if (model_.normal != study::NormalModel::EdemHysteretic)
    for (const auto& m : table_.materials)
      if (!(m.youngs_Pa > 0) || !(m.poisson >= 0 && m.poisson < 0.5))
        throw std::invalid_argument("builtin DEM: material '" + m.name + "' needs E > 0 and 0 <= nu < 0.5 for hooke models");
  if (model_.normal == study::NormalModel::HookeHysteresis && !(model_.coefficient_max_elastic_stiffness > 1))
    throw std::invalid_argument("builtin DEM: hooke/hysteresis needs coefficient_max_elastic_stiffness > 1");
  for (int c = 0; c < 3; ++c)
    if (!(domain_.hi[c] > domain_.lo[c])) throw std::invalid_argument("builtin DEM: empty domain");
}

int DemSimulation::addParticle(const ParticleState& p) {
  if (!(p.radius > 0)) throw std::invalid_argument("builtin DEM: particle radius must be > 0");
  useMaterial(p.material, true);
  const double rho = table_.materials[p.material].density_kg_m3;
  const double m = rho * 4.0 / 3.0 * kPi * p.radius * p.radius * p.radius;
  for (int c = 0; c < 3; ++c) {
    x_.push_back(p.x[c]);
    v_.push_back(p.v[c]);
    w_.push_back(p.w[c]);
    f_.push_back(0);
    t_.push_back(0);
    x_build_.push_back(p.x[c]);
  }
  radius_.push_back(p.radius);
  mass_.push_back(m);
  inv_mass_.push_back(1.0 / m);
  inv_inertia_.push_back(1.0 / (0.4 * m * p.radius * p.radius));
  material_.push_back(p.material);
  layer_.push_back(p.layer);
  dropWallContacts();  // the parts' ranges move with the count
  lists_valid_ = false;
  return static_cast<int>(radius_.size() - 1);
}

void DemSimulation::setParticleMaterial(int i, int material, int layer) {
  useMaterial(material, true);
  const double r = radius_[i];
  const double m = table_.materials.at(material).density_kg_m3 * 4.0 / 3.0 * kPi * r * r * r;
  material_[i] = material;
  layer_[i] = layer;
  mass_[i] = m;
  inv_mass_[i] = 1.0 / m;
  inv_inertia_[i] = 1.0 / (0.4 * m * r * r);
  lists_valid_ = false;  // pair stiffness depends on the material
}

void DemSimulation::keepParticles(const std::vector<char>& keep) {
  std::size_t k = 0;
  for (std::size_t i = 0; i < particleCount(); ++i) {
    if (!keep[i]) continue;
    for (int c = 0; c < 3; ++c) {
      x_[3 * k + c] = x_[3 * i + c];
      v_[3 * k + c] = v_[3 * i + c];
      w_[3 * k + c] = w_[3 * i + c];
      x_build_[3 * k + c] = x_build_[3 * i + c];
    }
    radius_[k] = radius_[i];
    mass_[k] = mass_[i];
    inv_mass_[k] = inv_mass_[i];
    inv_inertia_[k] = inv_inertia_[i];
    material_[k] = material_[i];
    layer_[k] = layer_[i];
    ++k;
  }
  for (auto* a : {&x_, &v_, &w_, &f_, &t_, &x_build_}) a->resize(3 * k);
  for (auto* a : {&radius_, &mass_, &inv_mass_, &inv_inertia_}) a->resize(k);
  material_.resize(k);
  layer_.resize(k);
  nb_start_.clear();
  nb_j_.clear();
  nb_i_.clear();
  nb_stiff_.clear();
  nb_hist_.clear();
  nb_touch_.clear();
  dropWallContacts();
  lists_valid_ = false;
}

int DemSimulation::addPlane(const PlaneWall& wall) {
  if (std::any_of(part_.begin(), part_.end(), [](const PartState& p) { return !p.wall.empty(); }))
    throw std::logic_error("builtin DEM: walls must be added before contacts exist");
  useMaterial(wall.material, false);
  PlaneWall p = wall;
  const double len = std::sqrt(p.normal[0] * p.normal[0] + p.normal[1] * p.normal[1] + p.normal[2] * p.normal[2]);
  if (!(len > 0)) throw std::invalid_argument("builtin DEM: plane normal is zero");
  for (double& c : p.normal) c /= len;
  planes_.push_back(p);
  plane_force_.push_back({0, 0, 0});
  return static_cast<int>(planes_.size() - 1);
}

int DemSimulation::addMesh(TriangleMesh mesh) {
  if (mesh.nodes.size() != mesh.rest_nodes.size()) mesh.nodes = mesh.rest_nodes;
  mesh.deformation_velocity.assign(mesh.nodes.size(), Vec3{0, 0, 0});
  useMaterial(mesh.material, false);
  for (const auto& t : mesh.triangles)
    for (auto id : t)
      if (id < 0 || static_cast<std::size_t>(id) >= mesh.nodes.size())
        throw std::invalid_argument("builtin DEM: mesh '" + mesh.name + "' has a triangle with node id " + std::to_string(id) +
                                    " outside 0.." + std::to_string(mesh.nodes.size() - 1));
  meshes_.push_back(std::move(mesh));
  mesh_bin_nodes_.emplace_back();
  mesh_build_nodes_.emplace_back();
  mesh_force_.emplace_back(meshes_.back().nodes.size() * 3, 0.0);
  mesh_impulse_.emplace_back(meshes_.back().nodes.size() * 3, 0.0);
  updateMeshBinNodes();
  lists_valid_ = false;
  return static_cast<int>(meshes_.size() - 1);
}

void DemSimulation::setMeshMotion(int m, const Vec3& origin, const Vec3& velocity, double t0) {
  auto& mesh = meshes_.at(m);
  mesh.origin = origin;
  mesh.velocity = velocity;
  mesh.t0 = t0;
  updateMeshBinNodes();
}

void DemSimulation::setNodePositions(int m, const std::vector<Vec3>& local, double interval_s) {
  auto& mesh = meshes_.at(m);
  if (local.size() != mesh.nodes.size())
    throw std::invalid_argument("builtin DEM: mesh '" + mesh.name + "' has " + std::to_string(mesh.nodes.size()) +
                                " nodes, got " + std::to_string(local.size()) + " positions");
  for (std::size_t k = 0; k < local.size(); ++k) {
    for (int c = 0; c < 3; ++c) {
      if (!std::isfinite(local[k][c]))
        throw std::invalid_argument("builtin DEM: mesh '" + mesh.name + "' node " + std::to_string(k) + " position is not finite");
      mesh.deformation_velocity[k][c] = interval_s > 0 ? (local[k][c] - mesh.nodes[k][c]) / interval_s : 0.0;
    }
  }
  mesh.nodes = local;
  updateMeshBinNodes();
}

void DemSimulation::resetNodeImpulse() {
  for (auto& imp : mesh_impulse_) std::fill(imp.begin(), imp.end(), 0.0);
}

void DemSimulation::updateMeshBinNodes() {
  for (std::size_t m = 0; m < meshes_.size(); ++m) {
    const auto off = meshes_[m].offset(time_);
    auto& bin = mesh_bin_nodes_[m];
    bin.resize(meshes_[m].nodes.size());
    for (std::size_t k = 0; k < bin.size(); ++k)
      for (int c = 0; c < 3; ++c) bin[k][c] = meshes_[m].nodes[k][c] + off[c];
  }
}

// ---------------------------------------------------------------- integration

void DemSimulation::setSettlingDamping(double rate_per_s) {
  if (!(rate_per_s >= 0 && std::isfinite(rate_per_s)))
    throw std::invalid_argument("builtin DEM: settling damping must be finite and >= 0 1/s, got " + std::to_string(rate_per_s));
  damping_per_s_ = rate_per_s;
}

void DemSimulation::run(long steps) {
  if (steps <= 0) return;
  if (!(dt_ > 0)) throw std::logic_error("builtin DEM: run() before setTimeStep()");
  for (long s = 0; s < steps; ++s) step(s + 1 < steps);
}

// Velocity Verlet (LAMMPS/LIGGGHTS nve/sphere): half kick and drift, forces, half kick, as phases
// of the team with the serial work between them (docs/builtin-dem.md, "Threads on a shared
// machine"). Each pass over the particles does all it can (the skin check and the force reset ride
// on the drift, the second kick and its health check on the wall forces' phase, and within a run
// the next step's drift too: two phases a step). A failure found in any part stops the step at the
// same point whichever part found it; it is raised after the phase.
void DemSimulation::step(bool drift_ahead) {
  const std::size_t n = particleCount();
  DEMFEM_ASSERT(x_.size() == 3 * n && v_.size() == 3 * n && w_.size() == 3 * n && f_.size() == 3 * n && t_.size() == 3 * n &&
                x_build_.size() == 3 * n && inv_mass_.size() == n && inv_inertia_.size() == n);
  DEMFEM_ASSERT(!drifted_ || (step_ > 0 && lists_valid_));
  resetFailures();
  if (step_ == 0 || !lists_valid_) {  // forces of the initial state for the first half kick
    updateMeshBinNodes();
    rebuildLists();
    const ForceReset reset = forceReset();
    team_.forEachPart([&](int part) {
      for (std::size_t i = rangeBegin(part); i < rangeEnd(part); ++i) reset(i, f_.data(), t_.data());
    });
    contactForces(false, false);
    raiseFailure();
  }
  if (!drifted_) team_.forEachPart([&](int part) { drift(part); });
  drifted_ = false;
  time_ += dt_;
  ++step_;
  updateMeshBinNodes();
  if (std::any_of(part_.begin(), part_.end(), [](const PartState& p) { return p.moved; }) || meshesMovedBeyondSkin())
    rebuildLists();
  contactForces(true, drift_ahead);
  raiseFailure();
  drifted_ = drift_ahead;
}

// The two sweeps are vectorised across particles (runVectorised, as the contact loops; this file
// is compiled without fused multiply-adds, so every instruction set gives the same bits). Their
// checks are flags or-ed over the particles, not branches per particle, nor a maximum of doubles
// (which GCC vectorises only under fast-math): the skin check asks whether any particle moved
// farther than half the skin, which is what the largest move was compared with.
void DemSimulation::drift(int part) {
  const VerletSweep s = verletSweep();
  const ForceReset reset = forceReset();
  const double limit_d2 = 0.25 * skin_ * skin_;
  const std::size_t lo = rangeBegin(part), hi = rangeEnd(part);
  std::int64_t moved = 0;
  const auto sweep = [&]<bool Damped>() {
    runVectorised([&]() DEMFEM_INLINE {
      std::int64_t any = 0;
      DEMFEM_INDEPENDENT_ITERATIONS
      for (std::size_t i = lo; i < hi; ++i) {
        s.halfKick(i);
        any |= s.move(i) > limit_d2 ? 1 : 0;
        reset.apply<Damped>(i, s.f, s.t);
      }
      moved = any;
    });
  };
  if (reset.damped())
    sweep.template operator()<true>();
  else
    sweep.template operator()<false>();
  part_[part].moved = moved != 0;
}

// Only when the health check finds a particle wrong does a second pass name the first.
void DemSimulation::kick(int part) {
  const VerletSweep s = verletSweep();
  const std::size_t lo = rangeBegin(part), hi = rangeEnd(part);
  std::int64_t sick = 0;
  runVectorised([&]() DEMFEM_INLINE {
    std::int64_t any = 0;
    DEMFEM_INDEPENDENT_ITERATIONS
    for (std::size_t i = lo; i < hi; ++i) {
      s.halfKick(i);
      any |= s.healthy(i) ? 0 : 1;
    }
    sick = any;
  });
  if (sick == 0 || part_[part].kick_bad >= 0) return;
  for (std::size_t i = lo; i < hi; ++i)
    if (!s.healthy(i)) {
      part_[part].kick_bad = static_cast<std::int64_t>(i);
      return;
    }
}

// Pair forces, then (unless a pair overlap failed) wall forces and, with then_kick, the second half
// kick of each part whose wall contacts did not fail, in the same phase: a particle's force is
// complete once its part has added the pair sums and its wall forces. With then_drift, a part whose
// particles all passed the health check goes on with the next step's drift (its particles' forces
// are final); a failing part leaves its particles as the failure found them, for the message.
void DemSimulation::contactForces(bool then_kick, bool then_drift) {
  team_.forEachPart([&](int part) { pairForces(part); });
  max_overlap_ = std::max_element(part_.begin(), part_.end(), [](const PartState& a, const PartState& b) {
                   return a.pair_max < b.pair_max;
                 })->pair_max;
  if (std::any_of(part_.begin(), part_.end(), [](const PartState& p) { return p.pair_bad >= 0; })) return;
  team_.forEachPart([&](int part) {
    sumPairForces(part);
    wallForces(part);
    if (!then_kick || part_[part].wall_bad >= 0) return;
    kick(part);
    if (then_drift && part_[part].kick_bad < 0) drift(part);
  });
  scatterWallForces();
  for (const auto& p : part_) max_overlap_ = std::max(max_overlap_, p.wall_max);
}

void DemSimulation::resetFailures() {
  for (auto& t : part_) {
    t.pair_max = t.wall_max = 0;
    t.pair_bad = t.wall_bad = t.kick_bad = -1;
    t.wall_bad_wall = -1;
  }
}

// The first failure in the order the step meets them: a pair overlap, a wall overlap, a particle
// that is not finite or left the domain (the lowest particle index of each kind).
void DemSimulation::raiseFailure() const {
  const auto first = [&](std::int64_t PartState::*bad) {
    for (const auto& t : part_)
      if (t.*bad >= 0) return t.*bad;
    return std::int64_t{-1};
  };
  if (const auto i = first(&PartState::pair_bad); i >= 0) {
    std::ostringstream msg;
    msg << "overlap with a neighbour exceeds " << overlapLimitFraction() << " of the smaller radius (largest overlap "
        << max_overlap_ * 1e3 << " mm); the time step may be too large for the contact stiffness";
    fail(static_cast<std::size_t>(i), msg.str());
  }
  if (const auto i = first(&PartState::wall_bad); i >= 0) fail(static_cast<std::size_t>(i), wallOverlapCause(i));
  std::int64_t bad = -1;
  for (const auto& t : part_)
    if (t.kick_bad >= 0 && (bad < 0 || t.kick_bad < bad)) bad = t.kick_bad;
  if (bad >= 0) {
    const std::size_t i = static_cast<std::size_t>(bad);
    bool finite = true;
    for (int c = 0; c < 3; ++c) finite = finite && std::isfinite(x_[3 * i + c]) && std::isfinite(v_[3 * i + c]);
    fail(i, finite ? "centre left the domain" : "position or velocity is not a number");
  }
}

// What a wall overlap beyond the limit says: which wall, and for a tool surface the two steps that
// can be too long (docs/builtin-dem.md, "Blow-up detection").
std::string DemSimulation::wallOverlapCause(std::int64_t particle) const {
  int wall = -1;
  for (const auto& t : part_)
    if (t.wall_bad == particle) wall = t.wall_bad_wall;
  std::ostringstream msg;
  msg << "overlap with ";
  const int P = static_cast<int>(planes_.size());
  if (wall >= P)
    msg << "the surface of '" << meshes_[static_cast<std::size_t>(wall - P)].name << "'";
  else
    msg << "a bin wall";
  msg << " exceeds " << overlapLimitFraction() << " of its radius";
  if (wall >= P)
    msg << "; the DEM step (dem.dt_fraction) or, on a tool the FEM client deforms, the coupling step fem.dt_s may be too "
           "long: a flexible tool deep in dense soil needs a shorter fem.dt_s than a rigid one";
  return msg.str();
}

void DemSimulation::fail(std::size_t i, const std::string& what) const {
  std::ostringstream msg;
  msg << "builtin DEM blew up at step " << step_ << " (t = " << time_ << " s): particle " << i << " at (" << x_[3 * i]
      << ", " << x_[3 * i + 1] << ", " << x_[3 * i + 2] << ") m, velocity (" << v_[3 * i] << ", " << v_[3 * i + 1] << ", "
      << v_[3 * i + 2] << ") m/s: " << what;
  throw BlowUp(msg.str());
}

// ---------------------------------------------------------------- state

ParticleState DemSimulation::particle(std::size_t i) const {
  ParticleState p;
  for (int c = 0; c < 3; ++c) {
    p.x[c] = x_[3 * i + c];
    p.v[c] = v_[3 * i + c];
    p.w[c] = w_[3 * i + c];
  }
  p.radius = radius_[i];
  p.material = material_[i];
  p.layer = layer_[i];
  return p;
}

double DemSimulation::kineticEnergy() const {
  double e = 0;
  for (std::size_t i = 0; i < particleCount(); ++i)
    e += 0.5 * mass_[i] * norm2(&v_[3 * i]) + 0.5 / inv_inertia_[i] * norm2(&w_[3 * i]);
  return e;
}

Vec3 DemSimulation::momentum() const {
  Vec3 p{0, 0, 0};
  for (std::size_t i = 0; i < particleCount(); ++i)
    for (int c = 0; c < 3; ++c) p[c] += mass_[i] * v_[3 * i + c];
  return p;
}

Vec3 DemSimulation::angularMomentum() const {
  Vec3 l{0, 0, 0};
  for (std::size_t i = 0; i < particleCount(); ++i) {
    double mv[3] = {mass_[i] * v_[3 * i], mass_[i] * v_[3 * i + 1], mass_[i] * v_[3 * i + 2]}, rxp[3];
    detail::cross3(&x_[3 * i], mv, rxp);
    for (int c = 0; c < 3; ++c) l[c] += rxp[c] + w_[3 * i + c] / inv_inertia_[i];
  }
  return l;
}

double DemSimulation::maxOverlap() const { return max_overlap_; }

std::size_t DemSimulation::contactCount() const {
  std::size_t c = 0;
  for (const auto& part : part_) c += part.wall.size();
  for (auto t : nb_touch_) c += t;
  return c;
}

std::size_t DemSimulation::bytesPerParticle() const {
  const std::size_t n = std::max<std::size_t>(1, particleCount());
  std::size_t b = 0;
  for (const auto* a : {&x_, &v_, &w_, &f_, &t_, &x_build_, &radius_, &mass_, &inv_mass_, &inv_inertia_}) b += a->capacity() * sizeof(double);
  b += (material_.capacity() + layer_.capacity() + nb_start_.capacity() + nb_j_.capacity() + nb_i_.capacity() + wc_start_.capacity() +
        wc_mesh_.capacity() + wc_tri_.capacity()) * sizeof(std::int32_t);
  b += nb_stiff_.capacity() * sizeof(ContactStiffness) + nb_hist_.capacity() * sizeof(double) + nb_touch_.capacity();
  for (const auto& t : part_) {
    b += (t.f.capacity() + t.t.capacity()) * sizeof(double);
    b += (t.wall.capacity() + t.wall_next.capacity()) * sizeof(WallContact);
    b += (t.wall_start.capacity() + t.wall_start_next.capacity()) * sizeof(std::int32_t);
  }
  return b / n;
}

}  // namespace demfem::builtin

#include "demfem/backends/builtin/simulation.hpp"

#include "demfem/adapter/output_files.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <numbers>
#include <sstream>
#include <tuple>

namespace demfem::builtin {

namespace {
constexpr double kPi = std::numbers::pi;
constexpr int kMaxWallCandidates = 32;  // touching features per particle before de-duplication
constexpr double kSameContact = 1e-6;    // contact points closer than this * radius are one contact

double norm2(const double* a) { return a[0] * a[0] + a[1] * a[1] + a[2] * a[2]; }
}  // namespace

// ---------------------------------------------------------------- materials

int MaterialTable::index(const std::string& name) const {
  for (std::size_t i = 0; i < materials.size(); ++i)
    if (materials[i].name == name) return static_cast<int>(i);
  throw std::invalid_argument("builtin DEM: material '" + name + "' is not in /soil/materials");
}

MaterialTable MaterialTable::fromSoil(const study::Soil& soil) {
  MaterialTable t;
  t.materials = soil.materials;
  const std::size_t n = t.materials.size();
  if (n == 0) throw std::invalid_argument("builtin DEM: /soil/materials is empty");
  t.laws.resize(n * n);
  for (std::size_t a = 0; a < n; ++a) {
    for (std::size_t b = 0; b < n; ++b) {
      const auto& ma = t.materials[a];
      const auto& mb = t.materials[b];
      const study::Interaction* found = nullptr;
      for (const auto& in : soil.interactions)
        if ((in.a == ma.name && in.b == mb.name) || (in.a == mb.name && in.b == ma.name)) found = &in;
      if (!found) continue;  // wall-wall pairs need none; DemSimulation::requirePair() checks use
      if (!(found->restitution > 0 && found->restitution <= 1))
        throw std::invalid_argument("builtin DEM: /soil/interactions '" + ma.name + "' - '" + mb.name +
                                    "': restitution must be in (0, 1], got " + std::to_string(found->restitution));
      PairLaw& law = t.laws[a * n + b];
      law.defined = true;
      law.restitution = found->restitution;
      law.friction = found->static_friction;
      law.rolling_friction = found->rolling_friction;
      law.cohesion_J_m3 = found->cohesion_J_m3;
      // yield_Pa = 0 means "not limiting" (walls): K1 uses the other material's yield strength.
      law.yield_min_Pa = ma.yield_Pa > 0 && mb.yield_Pa > 0 ? std::min(ma.yield_Pa, mb.yield_Pa)
                                                             : std::max(ma.yield_Pa, mb.yield_Pa);
      law.youngs_eff_Pa = 1.0 / ((1 - ma.poisson * ma.poisson) / ma.youngs_Pa + (1 - mb.poisson * mb.poisson) / mb.youngs_Pa);
      law.log_restitution = std::log(std::min(found->restitution, 1.0 - 1e-12));
    }
  }
  return t;
}

// ---------------------------------------------------------------- construction

DemSimulation::DemSimulation(const study::Soil& soil, const Domain& domain, int threads)
    : table_(MaterialTable::fromSoil(soil)),
      model_(soil.contact),
      layout_(HistoryLayout::of(soil.contact)),
      domain_(domain),
      threads_(std::max(1, threads)) {
  used_.assign(table_.materials.size(), 0);
  if (model_.normal != study::NormalModel::EdemHysteretic)
    for (const auto& m : table_.materials)
      if (!(m.youngs_Pa > 0) || !(m.poisson >= 0 && m.poisson < 0.5))
        throw std::invalid_argument("builtin DEM: material '" + m.name + "' needs E > 0 and 0 <= nu < 0.5 for hooke models");
  if (model_.normal == study::NormalModel::HookeHysteresis && !(model_.coefficient_max_elastic_stiffness > 1))
    throw std::invalid_argument("builtin DEM: hooke/hysteresis needs coefficient_max_elastic_stiffness > 1");
  for (int c = 0; c < 3; ++c)
    if (!(domain_.hi[c] > domain_.lo[c])) throw std::invalid_argument("builtin DEM: empty domain");
  if (threads_ > 1) {
    thread_f_.resize(threads_);
    thread_t_.resize(threads_);
  }
  thread_wall_.resize(threads_);
}

void DemSimulation::useMaterial(int material, bool particle) {
  if (material < 0 || material >= static_cast<int>(table_.materials.size()))
    throw std::invalid_argument("builtin DEM: material index " + std::to_string(material) + " out of range");
  if (particle && model_.normal == study::NormalModel::EdemHysteretic && !(table_.materials[material].yield_Pa > 0))
    throw std::invalid_argument("builtin DEM: particle material '" + table_.materials[material].name +
                                "' needs yield_Pa > 0 for the EDEM hysteretic spring (K1 = 5 R* min(Y))");
  const std::uint8_t flag = particle ? 2 : 1;
  if (used_[material] & flag) return;
  used_[material] |= flag;
  // Every particle material meets every used material (particles and walls).
  for (std::size_t other = 0; other < used_.size(); ++other) {
    if (!used_[other] || (!particle && !(used_[other] & 2))) continue;
    if (!table_.law(material, static_cast<int>(other)).defined)
      throw std::invalid_argument("builtin DEM: /soil/interactions has no entry for the pair '" +
                                  table_.materials[material].name + "' - '" + table_.materials[other].name + "'");
  }
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
  nb_stiff_.clear();
  nb_hist_.clear();
  nb_touch_.clear();
  wall_contacts_.clear();
  wall_start_.clear();
  lists_valid_ = false;
}

int DemSimulation::addPlane(const PlaneWall& wall) {
  if (!wall_contacts_.empty()) throw std::logic_error("builtin DEM: walls must be added before contacts exist");
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

// ---------------------------------------------------------------- time step

ContactStiffness DemSimulation::wallStiffness(int i, int wall_material) const {
  return contactStiffness(model_, table_.law(material_[i], wall_material), radius_[i], mass_[i]);
}

double DemSimulation::criticalTimeStep(study::TimeStepCriterion criterion) const {
  if (particleCount() == 0) throw std::logic_error("builtin DEM: no particles to derive a time step from");
  const double rmin = *std::min_element(radius_.begin(), radius_.end());
  if (criterion == study::TimeStepCriterion::Rayleigh) {
    // Rayleigh step: dt_R = pi R sqrt(rho/G) / (0.1631 nu + 0.8766) (docs/architecture.md section 11).
    double dt = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < particleCount(); ++i) {
      const auto& m = table_.materials[material_[i]];
      const double g = m.youngs_Pa / (2 * (1 + m.poisson));
      dt = std::min(dt, kPi * rmin * std::sqrt(m.density_kg_m3 / g) / (0.1631 * m.poisson + 0.8766));
    }
    return dt;
  }
  return kPi / 2.0 * stabilityLimit();  // pi sqrt(m*/k_max): contact half period of the stiffest spring
}

double DemSimulation::stabilityLimit() const {
  // Smallest sqrt(m*/k_max) over particle-particle (smallest particle of each material pair) and
  // particle-wall contacts (every wall material in the table).
  const std::size_t nm = table_.materials.size();
  std::vector<double> rmin(nm, std::numeric_limits<double>::infinity());
  for (std::size_t i = 0; i < particleCount(); ++i) rmin[material_[i]] = std::min(rmin[material_[i]], radius_[i]);
  double limit = std::numeric_limits<double>::infinity();
  const auto mass = [&](std::size_t m, double r) { return table_.materials[m].density_kg_m3 * 4.0 / 3.0 * kPi * r * r * r; };
  for (std::size_t a = 0; a < nm; ++a) {
    if (!std::isfinite(rmin[a])) continue;
    const double ma = mass(a, rmin[a]);
    for (std::size_t b = 0; b < nm; ++b) {
      if (!used_[b]) continue;
      const PairLaw& law = table_.law(static_cast<int>(a), static_cast<int>(b));
      // wall contact (b as wall material)
      const auto sw = contactStiffness(model_, law, rmin[a], ma);
      limit = std::min(limit, 2.0 * std::sqrt(ma / stiffestSpring(model_, law, sw)));
      if (!std::isfinite(rmin[b])) continue;
      const double mb = mass(b, rmin[b]);
      const double meff = ma * mb / (ma + mb), reff = rmin[a] * rmin[b] / (rmin[a] + rmin[b]);
      const auto sp = contactStiffness(model_, law, reff, meff);
      limit = std::min(limit, 2.0 * std::sqrt(meff / stiffestSpring(model_, law, sp)));
    }
  }
  return limit;
}

void DemSimulation::setTimeStep(double dt) {
  if (!(dt > 0)) throw std::invalid_argument("builtin DEM: time step must be > 0");
  if (particleCount() > 0) {
    const double limit = stabilityLimit();
    if (dt > limit)
      throw std::invalid_argument("builtin DEM: time step " + std::to_string(dt) + " s exceeds the stability limit " +
                                  std::to_string(limit) + " s of the stiffest contact spring (2 sqrt(m*/k_max))");
  }
  dt_ = dt;
}

// ---------------------------------------------------------------- lists

struct DemSimulation::CellGrid {
  Vec3 lo;
  double size = 0;
  int n[3] = {1, 1, 1};
  std::vector<std::int32_t> start, items;  // counting-sorted particle ids per cell
  // Clamped before the conversion: a wall node far outside the grid (a peer may place a mesh
  // anywhere) or a non-finite one lands in an edge cell instead of overflowing the int.
  int cellOf(double c, int axis) const {
    const double k = std::floor((c - lo[axis]) / size);
    if (!(k > 0)) return 0;
    return static_cast<int>(std::min(k, static_cast<double>(n[axis] - 1)));
  }
  std::size_t index(int i, int j, int k) const { return (static_cast<std::size_t>(k) * n[1] + j) * n[0] + i; }
};

// Particles are checked in the drift loop of step(); this covers the mesh nodes.
bool DemSimulation::meshesMovedBeyondSkin() const {
  const double lim2 = 0.25 * skin_ * skin_;
  for (std::size_t m = 0; m < meshes_.size(); ++m)
    for (std::size_t k = 0; k < mesh_bin_nodes_[m].size(); ++k) {
      const double d[3] = {mesh_bin_nodes_[m][k][0] - mesh_build_nodes_[m][k][0],
                           mesh_bin_nodes_[m][k][1] - mesh_build_nodes_[m][k][1],
                           mesh_bin_nodes_[m][k][2] - mesh_build_nodes_[m][k][2]};
      if (norm2(d) > lim2) return true;
    }
  return false;
}

void DemSimulation::rebuildLists() {
  const std::size_t n = particleCount();
  const double rmin = n ? *std::min_element(radius_.begin(), radius_.end()) : 0.0;
  const double rmax = n ? *std::max_element(radius_.begin(), radius_.end()) : 0.0;
  if (skin_ == 0) skin_ = 0.2 * rmin;  // fixed at the first build (part of the saved state)
  // Cells of edge >= 2 rmax + skin over the particles' bounding box (within the domain).
  CellGrid g;
  g.size = std::max(2 * rmax + skin_, 1e-6);
  Vec3 hi = domain_.lo;
  g.lo = domain_.hi;
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) {
      g.lo[c] = std::min(g.lo[c], std::max(x_[3 * i + c], domain_.lo[c]));
      hi[c] = std::max(hi[c], std::min(x_[3 * i + c], domain_.hi[c]));
    }
  for (int c = 0; c < 3; ++c) {
    if (n == 0) g.lo[c] = hi[c] = domain_.lo[c];
    g.n[c] = std::clamp(static_cast<int>((hi[c] - g.lo[c]) / g.size) + 1, 1, 4096);
  }
  const std::size_t cells = static_cast<std::size_t>(g.n[0]) * g.n[1] * g.n[2];
  std::vector<std::int32_t> cell_of(n);
  g.start.assign(cells + 1, 0);
  for (std::size_t i = 0; i < n; ++i) {
    cell_of[i] = static_cast<std::int32_t>(
        g.index(g.cellOf(x_[3 * i], 0), g.cellOf(x_[3 * i + 1], 1), g.cellOf(x_[3 * i + 2], 2)));
    ++g.start[cell_of[i] + 1];
  }
  for (std::size_t c = 0; c < cells; ++c) g.start[c + 1] += g.start[c];
  g.items.resize(n);
  {
    std::vector<std::int32_t> fill(g.start.begin(), g.start.end() - 1);
    for (std::size_t i = 0; i < n; ++i) g.items[fill[cell_of[i]]++] = static_cast<std::int32_t>(i);
  }
  buildNeighbourList(g);
  buildWallCandidates(g);
  x_build_ = x_;
  mesh_build_nodes_ = mesh_bin_nodes_;
  lists_valid_ = true;
}

void DemSimulation::buildNeighbourList(const CellGrid& g) {
  const std::size_t n = particleCount();
  const int T = threads_;
  std::vector<std::vector<std::int32_t>> rows_j(T);
  std::vector<std::int32_t> row_len(n, 0);
#pragma omp parallel num_threads(T)
  {
    const int tid = omp_get_thread_num();
    const std::size_t lo = n * tid / T, hi = n * (tid + 1) / T;
    auto& out = rows_j[tid];
    std::vector<std::int32_t> row;
    for (std::size_t i = lo; i < hi; ++i) {
      row.clear();
      const int ci = g.cellOf(x_[3 * i], 0), cj = g.cellOf(x_[3 * i + 1], 1), ck = g.cellOf(x_[3 * i + 2], 2);
      for (int k = std::max(ck - 1, 0); k <= std::min(ck + 1, g.n[2] - 1); ++k)
        for (int j = std::max(cj - 1, 0); j <= std::min(cj + 1, g.n[1] - 1); ++j)
          for (int ii = std::max(ci - 1, 0); ii <= std::min(ci + 1, g.n[0] - 1); ++ii) {
            const std::size_t c = g.index(ii, j, k);
            for (std::int32_t s = g.start[c]; s < g.start[c + 1]; ++s) {
              const std::int32_t jj = g.items[s];
              if (static_cast<std::size_t>(jj) <= i) continue;
              const double d[3] = {x_[3 * i] - x_[3 * jj], x_[3 * i + 1] - x_[3 * jj + 1], x_[3 * i + 2] - x_[3 * jj + 2]};
              const double cut = radius_[i] + radius_[jj] + skin_;
              if (norm2(d) < cut * cut) row.push_back(jj);
            }
          }
      std::sort(row.begin(), row.end());
      row_len[i] = static_cast<std::int32_t>(row.size());
      out.insert(out.end(), row.begin(), row.end());
    }
  }
  std::vector<std::int32_t> start(n + 1, 0);
  for (std::size_t i = 0; i < n; ++i) start[i + 1] = start[i] + row_len[i];
  std::vector<std::int32_t> nbj;
  nbj.reserve(start[n]);
  for (const auto& r : rows_j) nbj.insert(nbj.end(), r.begin(), r.end());

  // Stiffness per slot and history carried over from the old list (rows sorted by j).
  const int H = layout_.size;
  std::vector<ContactStiffness> stiff(nbj.size());
  std::vector<double> hist(nbj.size() * H, 0.0);
  std::vector<std::uint8_t> touch(nbj.size(), 0);
  const bool carry = nb_start_.size() == n + 1;
#pragma omp parallel for num_threads(T) schedule(static)
  for (std::size_t i = 0; i < n; ++i) {
    std::int32_t o = carry ? nb_start_[i] : 0;
    const std::int32_t oend = carry ? nb_start_[i + 1] : 0;
    for (std::int32_t s = start[i]; s < start[i + 1]; ++s) {
      const std::int32_t j = nbj[s];
      const double ri = radius_[i], rj = radius_[j];
      const double mi = mass_[i], mj = mass_[j];
      stiff[s] = contactStiffness(model_, table_.law(material_[i], material_[j]), ri * rj / (ri + rj), mi * mj / (mi + mj));
      while (o < oend && nb_j_[o] < j) ++o;
      if (o < oend && nb_j_[o] == j) {
        touch[s] = nb_touch_[o];
        for (int h = 0; h < H; ++h) hist[static_cast<std::size_t>(s) * H + h] = nb_hist_[static_cast<std::size_t>(o) * H + h];
      }
    }
  }
  thread_window_end_.assign(T, 0);
  for (int t = 0; t < T; ++t) {
    const std::size_t lo = n * t / T, hi = n * (t + 1) / T;
    std::size_t end = hi;
    for (std::int32_t s = start[lo]; s < start[hi]; ++s) end = std::max(end, static_cast<std::size_t>(nbj[s]) + 1);
    thread_window_end_[t] = end;
  }
  nb_start_ = std::move(start);
  nb_j_ = std::move(nbj);
  nb_stiff_ = std::move(stiff);
  nb_hist_ = std::move(hist);
  nb_touch_ = std::move(touch);
}

void DemSimulation::buildWallCandidates(const CellGrid& g) {
  const std::size_t n = particleCount();
  struct Cand {
    std::int32_t particle, mesh, tri;
  };
  std::vector<Cand> cands;
  for (std::size_t m = 0; m < meshes_.size(); ++m) {
    const auto& nodes = mesh_bin_nodes_[m];
    const auto& tris = meshes_[m].triangles;
    for (std::size_t t = 0; t < tris.size(); ++t) {
      Vec3 lo, hi;
      for (int c = 0; c < 3; ++c) {
        lo[c] = std::min({nodes[tris[t][0]][c], nodes[tris[t][1]][c], nodes[tris[t][2]][c]});
        hi[c] = std::max({nodes[tris[t][0]][c], nodes[tris[t][1]][c], nodes[tris[t][2]][c]});
      }
      const double reach = g.size;  // >= 2 rmax + skin
      int c0[3], c1[3];
      bool outside = false;
      for (int c = 0; c < 3; ++c) {
        if (hi[c] + reach < g.lo[c] || lo[c] - reach > g.lo[c] + g.size * g.n[c]) outside = true;
        c0[c] = g.cellOf(lo[c] - reach, c);
        c1[c] = g.cellOf(hi[c] + reach, c);
      }
      if (outside) continue;
      for (int k = c0[2]; k <= c1[2]; ++k)
        for (int j = c0[1]; j <= c1[1]; ++j)
          for (int i = c0[0]; i <= c1[0]; ++i) {
            const std::size_t c = g.index(i, j, k);
            for (std::int32_t s = g.start[c]; s < g.start[c + 1]; ++s) {
              const std::int32_t p = g.items[s];
              double d2 = 0;
              for (int a = 0; a < 3; ++a) {
                const double xa = x_[3 * p + a];
                const double e = xa < lo[a] ? lo[a] - xa : (xa > hi[a] ? xa - hi[a] : 0.0);
                d2 += e * e;
              }
              const double cut = radius_[p] + skin_;
              if (d2 < cut * cut) cands.push_back({p, static_cast<std::int32_t>(m), static_cast<std::int32_t>(t)});
            }
          }
    }
  }
  std::sort(cands.begin(), cands.end(), [](const Cand& a, const Cand& b) {
    return std::tie(a.particle, a.mesh, a.tri) < std::tie(b.particle, b.mesh, b.tri);
  });
  wc_start_.assign(n + 1, 0);
  wc_mesh_.resize(cands.size());
  wc_tri_.resize(cands.size());
  for (std::size_t c = 0; c < cands.size(); ++c) {
    ++wc_start_[cands[c].particle + 1];
    wc_mesh_[c] = cands[c].mesh;
    wc_tri_[c] = cands[c].tri;
  }
  for (std::size_t i = 0; i < n; ++i) wc_start_[i + 1] += wc_start_[i];
  // Plane walls: only particles within radius + skin of one can touch it before the next build.
  near_plane_.assign(n, 0);
  for (std::size_t i = 0; i < n; ++i)
    for (const auto& pl : planes_) {
      const double dist = (x_[3 * i] - pl.point[0]) * pl.normal[0] + (x_[3 * i + 1] - pl.point[1]) * pl.normal[1] +
                          (x_[3 * i + 2] - pl.point[2]) * pl.normal[2];
      if (dist < radius_[i] + skin_) near_plane_[i] = 1;
    }
}

// ---------------------------------------------------------------- forces

template <study::NormalModel N, study::RollingModel R>
void DemSimulation::pairForces() {
  const std::size_t n = particleCount();
  const int T = threads_;
  const int H = layout_.size;
  const double dt = dt_;
  std::vector<double> thread_max(T, 0.0);
  std::vector<std::int64_t> thread_bad(T, -1);
#pragma omp parallel num_threads(T)
  {
    const int tid = omp_get_thread_num();
    // Thread tid owns rows [lo, hi); it writes particles [lo, window_end) only (half list: j > i),
    // so its buffer is cleared and summed over that window alone.
    const std::size_t lo = n * tid / T, hi = n * (tid + 1) / T, window_end = thread_window_end_[tid];
    double* F = f_.data();
    double* Tq = t_.data();
    if (T > 1) {
      thread_f_[tid].resize(3 * n);
      thread_t_[tid].resize(3 * n);
      std::fill(thread_f_[tid].begin() + 3 * lo, thread_f_[tid].begin() + 3 * window_end, 0.0);
      std::fill(thread_t_[tid].begin() + 3 * lo, thread_t_[tid].begin() + 3 * window_end, 0.0);
      F = thread_f_[tid].data();
      Tq = thread_t_[tid].data();
    }
    double local_max = 0;
    std::int64_t bad = -1;
    for (std::size_t i = lo; i < hi; ++i) {
      const double xi = x_[3 * i], yi = x_[3 * i + 1], zi = x_[3 * i + 2];
      const double ri = radius_[i];
      const PairLaw* laws_i = &table_.law(material_[i], 0);  // row of i's material
      // i's sums stay in registers over its row (no store-load chain through F[i] per contact).
      double fi[3] = {0, 0, 0}, ti[3] = {0, 0, 0};
      for (std::int32_t s = nb_start_[i]; s < nb_start_[i + 1]; ++s) {
        const std::size_t j = static_cast<std::size_t>(nb_j_[s]);
        const double d[3] = {xi - x_[3 * j], yi - x_[3 * j + 1], zi - x_[3 * j + 2]};
        const double rj = radius_[j];
        const double rs = ri + rj;
        const double r2 = norm2(d);
        double* hist = nb_hist_.data() + static_cast<std::size_t>(s) * H;
        if (r2 >= rs * rs) {
          if (nb_touch_[s]) {
            nb_touch_[s] = 0;
            for (int h = 0; h < H; ++h) hist[h] = 0;
          }
          continue;
        }
        if (!nb_touch_[s]) nb_touch_[s] = 1;
        ContactKinematics k;
        const double r = std::sqrt(r2);
        const double rinv = 1.0 / r;
        for (int c = 0; c < 3; ++c) k.n[c] = d[c] * rinv;
        k.delta = rs - r;
        if (k.delta > local_max) local_max = k.delta;
        if (k.delta > overlapLimitFraction() * std::min(ri, rj) && bad < 0) bad = static_cast<std::int64_t>(i);
        k.r = r;
        k.ri = ri;
        k.rj = rj;
        k.reff = ri * rj / rs;
        k.di = ri - 0.5 * k.delta;
        k.dj = rj - 0.5 * k.delta;
        double vr[3], wr[3];
        for (int c = 0; c < 3; ++c) {
          vr[c] = v_[3 * i + c] - v_[3 * j + c];
          k.wi[c] = w_[3 * i + c];
          k.wj[c] = w_[3 * j + c];
          k.wrel[c] = k.wi[c] - k.wj[c];
          wr[c] = k.di * k.wi[c] + k.dj * k.wj[c];
        }
        k.vn = detail::dot3(vr, k.n);
        double wxn[3];
        detail::cross3(wr, k.n, wxn);
        for (int c = 0; c < 3; ++c) k.vt[c] = vr[c] - k.vn * k.n[c] - wxn[c];
        const ContactResult res =
            contactForce<N, R>(model_, layout_, laws_i[material_[j]], nb_stiff_[s], k, dt, hist, false);
        for (int c = 0; c < 3; ++c) {
          fi[c] += res.force[c];
          F[3 * j + c] -= res.force[c];
          ti[c] += res.torque_i[c];
          Tq[3 * j + c] += res.torque_j[c];
        }
      }
      for (int c = 0; c < 3; ++c) {
        F[3 * i + c] += fi[c];
        Tq[3 * i + c] += ti[c];
      }
    }
    thread_max[tid] = local_max;
    thread_bad[tid] = bad;
    if (T > 1) {  // every thread takes this branch
#pragma omp barrier
#pragma omp for schedule(static)
      for (std::size_t i = 0; i < n; ++i) {
        double fs[3] = {f_[3 * i], f_[3 * i + 1], f_[3 * i + 2]};
        double ts[3] = {t_[3 * i], t_[3 * i + 1], t_[3 * i + 2]};
        for (int t = 0; t < T; ++t) {
          if (i < n * t / T || i >= thread_window_end_[t]) continue;
          for (int c = 0; c < 3; ++c) {
            fs[c] += thread_f_[t][3 * i + c];
            ts[c] += thread_t_[t][3 * i + c];
          }
        }
        for (int c = 0; c < 3; ++c) {
          f_[3 * i + c] = fs[c];
          t_[3 * i + c] = ts[c];
        }
      }
    }
  }
  max_overlap_ = *std::max_element(thread_max.begin(), thread_max.end());
  for (int t = 0; t < T; ++t)
    if (thread_bad[t] >= 0) {
      const std::size_t i = static_cast<std::size_t>(thread_bad[t]);
      std::ostringstream msg;
      msg << "overlap with a neighbour exceeds " << overlapLimitFraction() << " of the smaller radius (largest overlap "
          << max_overlap_ * 1e3 << " mm); the time step may be too large for the contact stiffness";
      fail(i, msg.str());
    }
}

template <study::NormalModel N, study::RollingModel R>
void DemSimulation::wallForces() {
  const std::size_t n = particleCount();
  const int T = threads_;
  const int P = static_cast<int>(planes_.size());
  const double dt = dt_;
  const int H = layout_.size;
  std::vector<double> thread_max(T, 0.0);
  std::vector<std::int64_t> thread_bad(T, -1);
  const bool have_old = wall_start_.size() == n + 1;

  struct Touch {
    std::int32_t wall;
    std::int64_t key;
    FeatureKind kind;
    Vec3 q, normal;
    double dist;
    std::int32_t nodes[3];
    double weights[3];
  };

#pragma omp parallel num_threads(T)
  {
    const int tid = omp_get_thread_num();
    auto& out = thread_wall_[tid];
    out.clear();
    double local_max = 0;
    std::int64_t bad = -1;
    Touch touch[kMaxWallCandidates];
    bool accepted[kMaxWallCandidates];
    int matched_old[kMaxWallCandidates];
#pragma omp for schedule(static)
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3 xi{x_[3 * i], x_[3 * i + 1], x_[3 * i + 2]};
      const double ri = radius_[i];
      int nt = 0;
      for (int p = 0; p < (near_plane_[i] ? P : 0); ++p) {
        const auto& pl = planes_[p];
        const double dist = (xi[0] - pl.point[0]) * pl.normal[0] + (xi[1] - pl.point[1]) * pl.normal[1] +
                            (xi[2] - pl.point[2]) * pl.normal[2];
        if (dist >= ri || nt == kMaxWallCandidates) continue;
        Touch& t = touch[nt++];
        t = Touch{p, 0, FeatureKind::Face, {xi[0] - dist * pl.normal[0], xi[1] - dist * pl.normal[1], xi[2] - dist * pl.normal[2]},
                  pl.normal, dist, {-1, -1, -1}, {0, 0, 0}};
      }
      for (std::int32_t c = wc_start_[i]; c < wc_start_[i + 1] && nt < kMaxWallCandidates; ++c) {
        const int m = wc_mesh_[c];
        const auto& tri = meshes_[m].triangles[wc_tri_[c]];
        const auto& nodes = mesh_bin_nodes_[m];
        const ClosestFeature f = closestFeature(xi, nodes[tri[0]], nodes[tri[1]], nodes[tri[2]], tri, wc_tri_[c]);
        const double d[3] = {xi[0] - f.point[0], xi[1] - f.point[1], xi[2] - f.point[2]};
        const double d2 = norm2(d);
        if (d2 >= ri * ri) continue;
        const double dist = std::sqrt(d2);
        Vec3 normal;
        if (dist > 0) {
          for (int a = 0; a < 3; ++a) normal[a] = d[a] / dist;
        } else {  // centre exactly on the surface: use the face normal
          const auto& A = nodes[tri[0]];
          const auto& B = nodes[tri[1]];
          const auto& C = nodes[tri[2]];
          const double u[3] = {B[0] - A[0], B[1] - A[1], B[2] - A[2]}, v[3] = {C[0] - A[0], C[1] - A[1], C[2] - A[2]};
          double nn[3];
          detail::cross3(u, v, nn);
          const double l = std::sqrt(norm2(nn));
          for (int a = 0; a < 3; ++a) normal[a] = nn[a] / l;
        }
        Touch& t = touch[nt++];
        t = Touch{P + m, f.key, f.kind, f.point, normal, dist, {tri[0], tri[1], tri[2]}, {f.weights[0], f.weights[1], f.weights[2]}};
      }
      if (nt == 0) continue;
      // De-duplicate (docs/architecture.md section 2): faces first; an edge or vertex seen from several
      // triangles is one contact; an edge/vertex belonging to an accepted face (or a vertex of an
      // accepted edge) of the same mesh is the same contact seen from a neighbour triangle.
      std::sort(touch, touch + nt, [](const Touch& a, const Touch& b) {
        return std::tie(a.wall, a.kind, a.key) < std::tie(b.wall, b.kind, b.key);
      });
      for (int a = 0; a < nt; ++a) {
        accepted[a] = true;
        if (touch[a].wall < P) continue;
        for (int b = 0; b < a && accepted[a]; ++b) {
          if (!accepted[b] || touch[b].wall != touch[a].wall) continue;
          const double gap[3] = {touch[a].q[0] - touch[b].q[0], touch[a].q[1] - touch[b].q[1], touch[a].q[2] - touch[b].q[2]};
          if (touch[b].key == touch[a].key || norm2(gap) < kSameContact * kSameContact * ri * ri) {
            accepted[a] = false;  // same feature, or the same point reached through a neighbour triangle
            break;
          }
          if (touch[a].kind == FeatureKind::Face || touch[b].kind == FeatureKind::Vertex) continue;
          // nodes of feature a (those with non-zero weight) all among b's triangle nodes (face) or edge nodes
          bool inside = true;
          for (int q = 0; q < 3; ++q) {
            if (touch[a].weights[q] == 0) continue;
            const std::int32_t node = touch[a].nodes[q];
            bool found = false;
            for (int r = 0; r < 3; ++r)
              if (touch[b].nodes[r] == node && (touch[b].kind == FeatureKind::Face || touch[b].weights[r] != 0)) found = true;
            inside = inside && found;
          }
          if (inside) accepted[a] = false;
        }
      }
      // Contact history: same (wall, feature) as before, or handed on from the one vanished contact
      // of the same wall when the particle slid onto a neighbouring feature.
      const std::int32_t o0 = have_old ? wall_start_[i] : 0, o1 = have_old ? wall_start_[i + 1] : 0;
      for (int a = 0; a < nt; ++a) {
        matched_old[a] = -1;
        if (!accepted[a]) continue;
        for (std::int32_t o = o0; o < o1; ++o)
          if (wall_contacts_[o].wall == touch[a].wall && wall_contacts_[o].key == touch[a].key) matched_old[a] = o;
      }
      for (int a = 0; a < nt; ++a) {
        if (!accepted[a] || matched_old[a] >= 0) continue;
        int vanished = -1, count = 0;
        for (std::int32_t o = o0; o < o1; ++o) {
          if (wall_contacts_[o].wall != touch[a].wall) continue;
          bool still = false;
          for (int b = 0; b < nt; ++b) still = still || (accepted[b] && matched_old[b] == o);
          if (!still) { vanished = o; ++count; }
        }
        int fresh = 0;
        for (int b = 0; b < nt; ++b) fresh += accepted[b] && matched_old[b] < 0 && touch[b].wall == touch[a].wall;
        if (count == 1 && fresh == 1) matched_old[a] = vanished;
      }
      for (int a = 0; a < nt; ++a) {
        if (!accepted[a]) continue;
        const Touch& t = touch[a];
        WallContact wc{};
        wc.particle = static_cast<std::int32_t>(i);
        wc.wall = t.wall;
        wc.key = t.key;
        const bool is_mesh = t.wall >= P;
        const int wall_material = is_mesh ? meshes_[t.wall - P].material : planes_[t.wall].material;
        if (matched_old[a] >= 0) {
          const WallContact& old = wall_contacts_[matched_old[a]];
          std::memcpy(wc.hist, old.hist, sizeof(wc.hist));
          wc.stiffness = old.stiffness;
        } else {
          wc.stiffness = wallStiffness(static_cast<int>(i), wall_material);
        }
        for (int q = 0; q < 3; ++q) {
          wc.nodes[q] = t.nodes[q];
          wc.weights[q] = t.weights[q];
        }
        ContactKinematics k;
        for (int c = 0; c < 3; ++c) k.n[c] = t.normal[c];
        k.delta = ri - t.dist;
        if (k.delta > local_max) local_max = k.delta;
        if (k.delta > overlapLimitFraction() * ri && bad < 0) bad = static_cast<std::int64_t>(i);
        k.r = t.dist;
        k.ri = ri;
        k.rj = 0;
        k.reff = ri;
        k.di = t.dist;
        k.dj = 0;
        double vwall[3] = {0, 0, 0};
        if (is_mesh) {
          const auto& mesh = meshes_[t.wall - P];
          for (int c = 0; c < 3; ++c) {
            vwall[c] = mesh.velocity[c];
            for (int q = 0; q < 3; ++q) vwall[c] += t.weights[q] * mesh.deformation_velocity[t.nodes[q]][c];
          }
        }
        double vr[3], wr[3];
        for (int c = 0; c < 3; ++c) {
          vr[c] = v_[3 * i + c] - vwall[c];
          k.wi[c] = w_[3 * i + c];
          k.wj[c] = 0;
          k.wrel[c] = k.wi[c];
          wr[c] = k.di * k.wi[c];
        }
        k.vn = detail::dot3(vr, k.n);
        double wxn[3];
        detail::cross3(wr, k.n, wxn);
        for (int c = 0; c < 3; ++c) k.vt[c] = vr[c] - k.vn * k.n[c] - wxn[c];
        const ContactResult res = contactForce<N, R>(model_, layout_, table_.law(material_[i], wall_material),
                                                     wc.stiffness, k, dt,
                                                     H ? wc.hist : nullptr, true);
        for (int c = 0; c < 3; ++c) {
          f_[3 * i + c] += res.force[c];
          t_[3 * i + c] += res.torque_i[c];
          wc.force[c] = res.force[c];
        }
        out.push_back(wc);
      }
    }
    thread_max[tid] = local_max;
    thread_bad[tid] = bad;
  }
  // Gather in particle order (static schedule: thread blocks are ascending).
  if (T == 1) {
    wall_contacts_.swap(thread_wall_[0]);  // the old contacts' memory is reused next step
  } else {
    wall_contacts_.clear();
    for (auto& v : thread_wall_) wall_contacts_.insert(wall_contacts_.end(), v.begin(), v.end());
  }
  wall_start_.assign(n + 1, 0);
  for (const auto& wc : wall_contacts_) ++wall_start_[wc.particle + 1];
  for (std::size_t i = 0; i < n; ++i) wall_start_[i + 1] += wall_start_[i];
  for (auto& mf : mesh_force_) std::fill(mf.begin(), mf.end(), 0.0);
  for (auto& pf : plane_force_) pf = {0, 0, 0};
  for (const auto& wc : wall_contacts_) {
    if (wc.wall < P) {
      for (int c = 0; c < 3; ++c) plane_force_[wc.wall][c] -= wc.force[c];
      continue;
    }
    auto& mf = mesh_force_[wc.wall - P];
    auto& mi = mesh_impulse_[wc.wall - P];
    for (int q = 0; q < 3; ++q) {
      if (wc.weights[q] == 0) continue;
      for (int c = 0; c < 3; ++c) {
        const double f = -wc.force[c] * wc.weights[q];
        mf[3 * wc.nodes[q] + c] += f;
        mi[3 * wc.nodes[q] + c] += f * dt;
      }
    }
  }
  max_overlap_ = std::max(max_overlap_, *std::max_element(thread_max.begin(), thread_max.end()));
  for (int t = 0; t < T; ++t)
    if (thread_bad[t] >= 0)
      fail(static_cast<std::size_t>(thread_bad[t]),
           "overlap with a wall exceeds " + std::to_string(overlapLimitFraction()) + " of its radius");
}

void DemSimulation::contactForces() {
  using NM = study::NormalModel;
  using RM = study::RollingModel;
  const auto dispatch = [&]<NM N>() {
    switch (model_.rolling) {
      case RM::None: pairForces<N, RM::None>(); wallForces<N, RM::None>(); break;
      case RM::EdemStandard: pairForces<N, RM::EdemStandard>(); wallForces<N, RM::EdemStandard>(); break;
      case RM::Cdt: pairForces<N, RM::Cdt>(); wallForces<N, RM::Cdt>(); break;
      case RM::Epsd: pairForces<N, RM::Epsd>(); wallForces<N, RM::Epsd>(); break;
    }
  };
  switch (model_.normal) {
    case NM::EdemHysteretic: dispatch.template operator()<NM::EdemHysteretic>(); break;
    case NM::Hooke: dispatch.template operator()<NM::Hooke>(); break;
    case NM::HookeHysteresis: dispatch.template operator()<NM::HookeHysteresis>(); break;
  }
}

// ---------------------------------------------------------------- integration

void DemSimulation::run(long steps) {
  if (steps <= 0) return;
  if (!(dt_ > 0)) throw std::logic_error("builtin DEM: run() before setTimeStep()");
  for (long s = 0; s < steps; ++s) step();
}

void DemSimulation::step() {
  const std::size_t n = particleCount();
  const double half = 0.5 * dt_;
  if (step_ == 0 || !lists_valid_) {  // forces of the initial state for the first half kick
    updateMeshBinNodes();
    rebuildLists();
#pragma omp parallel for num_threads(threads_) schedule(static)
    for (std::size_t i = 0; i < n; ++i) resetForce(i);
    contactForces();
  }
  // Velocity Verlet (LAMMPS/LIGGGHTS nve/sphere): half kick and drift, forces, half kick. Each
  // pass over the particles does all it can (the skin check and the force reset ride on the drift,
  // the health check on the second kick): one sweep of the arrays and one thread fork per pass.
  const double lim2 = 0.25 * skin_ * skin_;
  int moved = 0;
#pragma omp parallel for num_threads(threads_) schedule(static) reduction(| : moved)
  for (std::size_t i = 0; i < n; ++i) {
    double d2 = 0;
    for (int c = 0; c < 3; ++c) {
      v_[3 * i + c] += half * f_[3 * i + c] * inv_mass_[i];
      w_[3 * i + c] += half * t_[3 * i + c] * inv_inertia_[i];
      x_[3 * i + c] += dt_ * v_[3 * i + c];
      const double d = x_[3 * i + c] - x_build_[3 * i + c];
      d2 += d * d;
    }
    if (d2 > lim2) moved = 1;
    resetForce(i);
  }
  time_ += dt_;
  ++step_;
  updateMeshBinNodes();
  if (moved || meshesMovedBeyondSkin()) rebuildLists();
  contactForces();
  std::int64_t bad = std::numeric_limits<std::int64_t>::max();
#pragma omp parallel for num_threads(threads_) schedule(static) reduction(min : bad)
  for (std::size_t i = 0; i < n; ++i) {
    bool ok = true;
    for (int c = 0; c < 3; ++c) {
      v_[3 * i + c] += half * f_[3 * i + c] * inv_mass_[i];
      w_[3 * i + c] += half * t_[3 * i + c] * inv_inertia_[i];
      ok = ok && std::isfinite(x_[3 * i + c]) && std::isfinite(v_[3 * i + c]) && std::isfinite(w_[3 * i + c]);
      ok = ok && x_[3 * i + c] >= domain_.lo[c] && x_[3 * i + c] <= domain_.hi[c];
    }
    if (!ok) bad = std::min<std::int64_t>(bad, static_cast<std::int64_t>(i));
  }
  if (bad != std::numeric_limits<std::int64_t>::max()) {
    const std::size_t i = static_cast<std::size_t>(bad);
    bool finite = true;
    for (int c = 0; c < 3; ++c) finite = finite && std::isfinite(x_[3 * i + c]) && std::isfinite(v_[3 * i + c]);
    fail(i, finite ? "centre left the domain" : "position or velocity is not a number");
  }
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
  std::size_t c = wall_contacts_.size();
  for (auto t : nb_touch_) c += t;
  return c;
}

std::size_t DemSimulation::bytesPerParticle() const {
  const std::size_t n = std::max<std::size_t>(1, particleCount());
  std::size_t b = 0;
  for (const auto* a : {&x_, &v_, &w_, &f_, &t_, &x_build_, &radius_, &mass_, &inv_mass_, &inv_inertia_}) b += a->capacity() * sizeof(double);
  b += (material_.capacity() + layer_.capacity() + nb_start_.capacity() + nb_j_.capacity() + wc_start_.capacity() +
        wc_mesh_.capacity() + wc_tri_.capacity() + wall_start_.capacity()) * sizeof(std::int32_t);
  b += nb_stiff_.capacity() * sizeof(ContactStiffness) + nb_hist_.capacity() * sizeof(double) + nb_touch_.capacity();
  b += wall_contacts_.capacity() * sizeof(WallContact);
  for (const auto& tf : thread_f_) b += tf.capacity() * sizeof(double);
  for (const auto& tt : thread_t_) b += tt.capacity() * sizeof(double);
  return b / n;
}

// ---------------------------------------------------------------- checkpoint

namespace {
constexpr char kStateTag[8] = {'D', 'F', 'D', 'E', 'M', 'S', 'T', '3'};

bool allFinite(const std::vector<double>& values) {
  return std::all_of(values.begin(), values.end(), [](double v) { return std::isfinite(v); });
}
bool allFinite(const std::vector<Vec3>& values) {
  return std::all_of(values.begin(), values.end(), [](const Vec3& v) {
    return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
  });
}

// A CSR offset array over `rows` rows into `items` entries: empty (no list yet) or rows + 1
// non-decreasing offsets from 0 to items.
bool isOffsets(const std::vector<std::int32_t>& start, std::size_t rows, std::size_t items) {
  if (start.empty()) return true;
  if (start.size() != rows + 1 || start.front() != 0 || static_cast<std::size_t>(start.back()) != items) return false;
  return std::is_sorted(start.begin(), start.end());
}
}  // namespace

void DemSimulation::saveState(adapter::PayloadWriter& out) const {
  out.put(kStateTag);
  out.put(static_cast<std::int32_t>(threads_));
  out.put(static_cast<std::int32_t>(layout_.size));
  out.put(static_cast<std::uint64_t>(table_.materials.size()));
  out.put(gravity_);
  out.put(dt_);
  out.put(time_);
  out.put(static_cast<std::int64_t>(step_));
  out.put(skin_);
  out.put(static_cast<std::uint8_t>(lists_valid_));
  out.put(max_overlap_);
  for (const auto* a : {&x_, &v_, &w_, &f_, &t_, &x_build_, &radius_, &mass_, &inv_mass_, &inv_inertia_}) out.putVector(*a);
  out.putVector(material_);
  out.putVector(layer_);
  out.putVector(used_);
  out.putVector(nb_start_);
  out.putVector(nb_j_);
  out.putVector(nb_stiff_);
  out.putVector(nb_hist_);
  out.putVector(nb_touch_);
  out.putVector(thread_window_end_);
  out.putVector(planes_);
  out.put(static_cast<std::uint64_t>(meshes_.size()));
  for (std::size_t m = 0; m < meshes_.size(); ++m) {
    const auto& mesh = meshes_[m];
    out.putString(mesh.name);
    out.putVector(mesh.rest_nodes);
    out.putVector(mesh.nodes);
    out.putVector(mesh.deformation_velocity);
    out.putVector(mesh.triangles);
    out.put(mesh.origin);
    out.put(mesh.velocity);
    out.put(mesh.t0);
    out.put(static_cast<std::int32_t>(mesh.material));
    out.putVector(mesh_build_nodes_[m]);
    out.putVector(mesh_force_[m]);
    out.putVector(mesh_impulse_[m]);
  }
  out.putVector(wc_start_);
  out.putVector(wc_mesh_);
  out.putVector(wc_tri_);
  out.putVector(near_plane_);
  out.putVector(wall_contacts_);
  out.putVector(wall_start_);
  out.putVector(plane_force_);
}

DemSimulation DemSimulation::withState(adapter::PayloadReader& in) const {
  const auto tag = in.get<std::array<char, sizeof kStateTag>>();
  if (std::memcmp(tag.data(), kStateTag, sizeof kStateTag) != 0) in.fail("not a builtin DEM state (bad tag)");
  const auto threads = in.get<std::int32_t>(), hist = in.get<std::int32_t>();
  const auto nmat = in.get<std::uint64_t>();
  if (threads != threads_)
    in.fail("written with " + std::to_string(threads) + " threads, this run has " + std::to_string(threads_) +
            " (bit-identical restart needs the same count)");
  if (hist != layout_.size || nmat != table_.materials.size())
    in.fail("written for another contact model or material table");
  DemSimulation s = *this;
  in.get(s.gravity_);
  in.get(s.dt_);
  in.get(s.time_);
  s.step_ = static_cast<long>(in.get<std::int64_t>());
  in.get(s.skin_);
  s.lists_valid_ = in.get<std::uint8_t>() != 0;
  in.get(s.max_overlap_);
  for (auto* a : {&s.x_, &s.v_, &s.w_, &s.f_, &s.t_, &s.x_build_, &s.radius_, &s.mass_, &s.inv_mass_, &s.inv_inertia_})
    in.getVector(*a);
  in.getVector(s.material_);
  in.getVector(s.layer_);
  in.getVector(s.used_);
  in.getVector(s.nb_start_);
  in.getVector(s.nb_j_);
  in.getVector(s.nb_stiff_);
  in.getVector(s.nb_hist_);
  in.getVector(s.nb_touch_);
  in.getVector(s.thread_window_end_);
  in.getVector(s.planes_);
  if (in.get<std::uint64_t>() != meshes_.size()) in.fail("mesh count differs from this simulation's");
  for (std::size_t m = 0; m < meshes_.size(); ++m) {
    auto& mesh = s.meshes_[m];
    mesh.name = in.getString();
    in.getVector(mesh.rest_nodes);
    in.getVector(mesh.nodes);
    in.getVector(mesh.deformation_velocity);
    in.getVector(mesh.triangles);
    in.get(mesh.origin);
    in.get(mesh.velocity);
    in.get(mesh.t0);
    mesh.material = in.get<std::int32_t>();
    in.getVector(s.mesh_build_nodes_[m]);
    in.getVector(s.mesh_force_[m]);
    in.getVector(s.mesh_impulse_[m]);
  }
  in.getVector(s.wc_start_);
  in.getVector(s.wc_mesh_);
  in.getVector(s.wc_tri_);
  in.getVector(s.near_plane_);
  in.getVector(s.wall_contacts_);
  in.getVector(s.wall_start_);
  in.getVector(s.plane_force_);
  s.checkRestoredAgainst(*this, in);
  s.updateMeshBinNodes();
  return s;
}

// What the study fixes must equal the live simulation's; what evolves must be finite, sized to
// the particles and meshes, and index only what exists. Nothing a corrupted but checksummed file
// holds can then make a later step read out of bounds.
void DemSimulation::checkRestoredAgainst(const DemSimulation& live, const adapter::PayloadReader& in) const {
  const std::size_t n = live.particleCount();
  const auto require = [&](bool ok, const char* what) {
    if (!ok) in.fail(what);
  };
  require(gravity_ == live.gravity_ && dt_ == live.dt_, "gravity or time step differs from this simulation's");
  require(radius_ == live.radius_ && mass_ == live.mass_ && inv_mass_ == live.inv_mass_ &&
              inv_inertia_ == live.inv_inertia_ && material_ == live.material_ && layer_ == live.layer_ &&
              used_ == live.used_,
          "the particles (count, sizes or materials) differ from this simulation's");
  require(planes_.size() == live.planes_.size() && plane_force_.size() == planes_.size(), "plane wall count differs");
  for (std::size_t p = 0; p < planes_.size(); ++p)
    require(planes_[p].point == live.planes_[p].point && planes_[p].normal == live.planes_[p].normal &&
                planes_[p].material == live.planes_[p].material,
            "a plane wall differs from this simulation's");
  for (std::size_t m = 0; m < meshes_.size(); ++m) {
    const auto &mesh = meshes_[m], &other = live.meshes_[m];
    const std::size_t nodes = other.rest_nodes.size();
    require(mesh.name == other.name && mesh.rest_nodes == other.rest_nodes && mesh.triangles == other.triangles &&
                mesh.material == other.material,
            "a mesh differs from this simulation's");
    require(mesh.nodes.size() == nodes && mesh.deformation_velocity.size() == nodes &&
                (mesh_build_nodes_[m].empty() || mesh_build_nodes_[m].size() == nodes) &&
                mesh_force_[m].size() == 3 * nodes && mesh_impulse_[m].size() == 3 * nodes,
            "mesh node arrays have the wrong size");
    require(allFinite(mesh.nodes) && allFinite(mesh.deformation_velocity) && allFinite(mesh_build_nodes_[m]) &&
                allFinite(mesh_force_[m]) && allFinite(mesh_impulse_[m]) && allFinite(std::vector<Vec3>{mesh.origin, mesh.velocity}) &&
                std::isfinite(mesh.t0),
            "a mesh value is not finite");
    require(!lists_valid_ || mesh_build_nodes_[m].size() == nodes, "mesh list positions missing");
  }
  require(std::isfinite(time_) && time_ >= 0 && step_ >= 0 && step_ <= adapter::kMaxDemSteps && std::isfinite(max_overlap_),
          "time or step count out of range");
  const double rmin = n ? *std::min_element(radius_.begin(), radius_.end()) : 0.0;
  require(skin_ == 0 || skin_ == 0.2 * rmin, "neighbour skin differs from this simulation's");
  for (const auto* a : {&x_, &v_, &w_, &f_, &t_, &x_build_})
    require(a->size() == 3 * n && allFinite(*a), "a particle array has the wrong size or a value that is not finite");
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c)
      require(x_[3 * i + c] >= domain_.lo[c] && x_[3 * i + c] <= domain_.hi[c], "a particle lies outside the domain");
  // Neighbour list: rows i hold sorted j > i.
  require(isOffsets(nb_start_, n, nb_j_.size()) && (!lists_valid_ || nb_start_.size() == n + 1),
          "neighbour list offsets are inconsistent");
  require(nb_stiff_.size() == nb_j_.size() && nb_touch_.size() == nb_j_.size() &&
              nb_hist_.size() == nb_j_.size() * static_cast<std::size_t>(layout_.size) && allFinite(nb_hist_),
          "neighbour list arrays have inconsistent sizes or values");
  for (std::size_t i = 0; i + 1 < nb_start_.size(); ++i)
    for (std::int32_t k = nb_start_[i]; k < nb_start_[i + 1]; ++k)
      require(static_cast<std::size_t>(nb_j_[k]) > i && static_cast<std::size_t>(nb_j_[k]) < n &&
                  (k == nb_start_[i] || nb_j_[k - 1] < nb_j_[k]),
              "a neighbour list entry is out of range or unsorted");
  for (const auto& k : nb_stiff_)
    require(std::isfinite(k.kn) && std::isfinite(k.kt) && std::isfinite(k.gamma_n) && std::isfinite(k.gamma_t),
            "a pair stiffness is not finite");
  require(thread_window_end_.empty() || thread_window_end_.size() == static_cast<std::size_t>(threads_),
          "thread windows have the wrong count");
  for (const auto end : thread_window_end_) require(end <= n, "a thread window ends past the particles");
  // Wall candidates and contacts.
  require(isOffsets(wc_start_, n, wc_mesh_.size()) && wc_tri_.size() == wc_mesh_.size() &&
              (!lists_valid_ || (wc_start_.size() == n + 1 && near_plane_.size() == n)) &&
              (near_plane_.empty() || near_plane_.size() == n),
          "wall candidate lists are inconsistent");
  for (std::size_t c = 0; c < wc_mesh_.size(); ++c)
    require(wc_mesh_[c] >= 0 && static_cast<std::size_t>(wc_mesh_[c]) < meshes_.size() && wc_tri_[c] >= 0 &&
                static_cast<std::size_t>(wc_tri_[c]) < meshes_[wc_mesh_[c]].triangles.size(),
            "a wall candidate names a mesh or triangle that does not exist");
  require(isOffsets(wall_start_, n, wall_contacts_.size()), "wall contact offsets are inconsistent");
  const std::size_t walls = planes_.size() + meshes_.size();
  for (std::size_t c = 0; c < wall_contacts_.size(); ++c) {
    const WallContact& wc = wall_contacts_[c];
    require(wc.particle >= 0 && static_cast<std::size_t>(wc.particle) < n && wc.wall >= 0 &&
                static_cast<std::size_t>(wc.wall) < walls && (c == 0 || wall_contacts_[c - 1].particle <= wc.particle),
            "a wall contact names a particle or wall that does not exist");
    require(wall_start_.empty() || (static_cast<std::size_t>(wall_start_[wc.particle]) <= c &&
                                    c < static_cast<std::size_t>(wall_start_[wc.particle + 1])),
            "a wall contact lies outside its particle's row");
    if (static_cast<std::size_t>(wc.wall) >= planes_.size())
      for (const auto node : wc.nodes)
        require(node >= 0 && static_cast<std::size_t>(node) < meshes_[wc.wall - planes_.size()].nodes.size(),
                "a wall contact names a mesh node that does not exist");
  }
}

void DemSimulation::loadState(adapter::PayloadReader& in) { *this = withState(in); }

// ---------------------------------------------------------------- VTK

void DemSimulation::writeParticlesVtk(const std::filesystem::path& file) const {
  std::ostringstream out;
  const std::size_t n = particleCount();
  out << "# vtk DataFile Version 3.0\ndemfem builtin DEM particles t = " << time_ << " s\nASCII\nDATASET POLYDATA\n";
  out << "POINTS " << n << " double\n";
  out.precision(9);
  for (std::size_t i = 0; i < n; ++i) out << x_[3 * i] << ' ' << x_[3 * i + 1] << ' ' << x_[3 * i + 2] << '\n';
  out << "VERTICES " << n << ' ' << 2 * n << '\n';
  for (std::size_t i = 0; i < n; ++i) out << "1 " << i << '\n';
  out << "POINT_DATA " << n << "\nSCALARS radius_m double 1\nLOOKUP_TABLE default\n";
  for (std::size_t i = 0; i < n; ++i) out << radius_[i] << '\n';
  out << "SCALARS layer int 1\nLOOKUP_TABLE default\n";
  for (std::size_t i = 0; i < n; ++i) out << layer_[i] << '\n';
  out << "VECTORS velocity_m_s double\n";
  for (std::size_t i = 0; i < n; ++i) out << v_[3 * i] << ' ' << v_[3 * i + 1] << ' ' << v_[3 * i + 2] << '\n';
  adapter::writeFileAtomically(file, out.str());
}

void DemSimulation::writeMeshVtk(int m, const std::filesystem::path& file) const {
  std::ostringstream out;
  const auto& nodes = mesh_bin_nodes_.at(m);
  const auto& tris = meshes_[m].triangles;
  out << "# vtk DataFile Version 3.0\ndemfem builtin DEM mesh " << meshes_[m].name << " t = " << time_
      << " s\nASCII\nDATASET POLYDATA\nPOINTS " << nodes.size() << " double\n";
  out.precision(17);  // round trip: the FEM client's files of the same instant compare to round-off
  for (const auto& p : nodes) out << p[0] << ' ' << p[1] << ' ' << p[2] << '\n';
  out << "POLYGONS " << tris.size() << ' ' << 4 * tris.size() << '\n';
  for (const auto& t : tris) out << "3 " << t[0] << ' ' << t[1] << ' ' << t[2] << '\n';
  out << "POINT_DATA " << nodes.size() << "\nVECTORS force_N double\n";
  const auto& f = mesh_force_[m];
  for (std::size_t k = 0; k < nodes.size(); ++k) out << f[3 * k] << ' ' << f[3 * k + 1] << ' ' << f[3 * k + 2] << '\n';
  adapter::writeFileAtomically(file, out.str());
}

}  // namespace demfem::builtin

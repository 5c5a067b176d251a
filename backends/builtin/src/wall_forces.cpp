// Particle-wall contact forces of the built-in DEM (docs/builtin-dem.md, "Mesh contacts without
// double counting"), in the steps of a contact search: the broad search (the candidates of the list
// build, neighbour_lists.cpp) is narrowed per particle to the wall features it touches (fine
// search), features reached through several triangles become one contact, each contact takes its
// history over from the last step, and the law's force is split to the mesh nodes. The contacts of
// a run of particles are gathered into a batch whose law runs as a vectorised loop, like the pair
// loop's (pair_forces.cpp), with the numbers of one contact after the other.
#include "demfem/backends/builtin/simulation.hpp"

#include "demfem/backends/physics/dem_assert.hpp"

#include "contact_kinematics.hpp"
#include "vectorised_loop.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <tuple>

namespace demfem::builtin {

using detail::norm2;

namespace {
constexpr int kMaxWallCandidates = 32;  // touching features per particle before de-duplication
constexpr std::size_t kWallBatchContacts = 128;  // contacts per batch (a particle's are not split)
constexpr double kNoHistory[HistoryLayout::kMaxSize] = {};  // a new contact's history
constexpr double kSameContact = 1e-6;    // contact points closer than this * radius are one contact
}  // namespace

// A wall feature one particle touches: wall index (planes first, then meshes), mesh-wide feature
// key and kind, the closest point q, the unit normal towards the particle, the centre distance, and
// the triangle's nodes with the barycentric weights of q (planes: nodes -1, weights 0).
struct WallTouch {
  std::int32_t wall;
  std::int64_t key;
  FeatureKind kind;
  Vec3 q, normal;
  double dist;
  std::int32_t nodes[3];
  double weights[3];
};

namespace {

// Unit normal of triangle (a, b, c) by the right-hand rule.
Vec3 faceNormal(const Vec3& a, const Vec3& b, const Vec3& c) {
  const double u[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, v[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
  double nn[3];
  detail::cross3(u, v, nn);
  const double l = std::sqrt(norm2(nn));
  return {nn[0] / l, nn[1] / l, nn[2] / l};
}

// Is touch a the same contact as the accepted touch b of the same mesh? The same feature, the same
// point reached through a neighbour triangle, or an edge/vertex whose nodes (those with non-zero
// weight) all belong to b's face or edge.
bool sameContact(const WallTouch& a, const WallTouch& b, double radius) {
  const double gap[3] = {a.q[0] - b.q[0], a.q[1] - b.q[1], a.q[2] - b.q[2]};
  if (b.key == a.key || norm2(gap) < kSameContact * kSameContact * radius * radius) return true;
  if (a.kind == FeatureKind::Face || b.kind == FeatureKind::Vertex) return false;
  bool inside = true;
  for (int q = 0; q < 3; ++q) {
    if (a.weights[q] == 0) continue;
    bool found = false;
    for (int r = 0; r < 3; ++r)
      if (b.nodes[r] == a.nodes[q] && (b.kind == FeatureKind::Face || b.weights[r] != 0)) found = true;
    inside = inside && found;
  }
  return inside;
}

// Feature de-duplication (docs/builtin-dem.md): sorts the touches (faces first within a wall) and
// accepts each that is not the same contact as an accepted one of its mesh. Planes are always distinct.
void acceptDistinct(WallTouch* touch, int nt, int planes, double radius, bool* accepted) {
  std::sort(touch, touch + nt, [](const WallTouch& a, const WallTouch& b) {
    return std::tie(a.wall, a.kind, a.key) < std::tie(b.wall, b.kind, b.key);
  });
  for (int a = 0; a < nt; ++a) {
    accepted[a] = true;
    if (touch[a].wall < planes) continue;
    for (int b = 0; b < a && accepted[a]; ++b)
      if (accepted[b] && touch[b].wall == touch[a].wall && sameContact(touch[a], touch[b], radius)) accepted[a] = false;
  }
}

// What the loops over a wall batch read: the simulation's particle arrays, the pair laws, and the
// batch.
struct WallInputs {
  const double *v, *w, *radius, *inv_inertia;
  const PairLaw* laws;
  const std::int32_t *i, *law;
  const ContactStiffness* stiffness;
  const double *n0, *n1, *n2, *dist, *vw0, *vw1, *vw2, *cohesion;
};

// The cohesive normal force of count wall contacts (cohesionForce<C> with a wall's geometry:
// R* = R_i, overlap R_i - distance).
template <study::CohesionModel C>
[[gnu::always_inline]] inline void wallCohesion(const WallInputs& inputs, std::size_t count, double* cohesion) {
  const WallInputs in = inputs;  // the arrays in registers: the stores below do not reach them
  DEMFEM_INDEPENDENT_ITERATIONS
  for (std::size_t k = 0; k < count; ++k) {
    const double ri = in.radius[in.i[k]], r = in.dist[k];
    cohesion[k] = cohesionForce<C>(in.laws[in.law[k]].cohesion_J_m3, ri, ri - r, ri, r, 0, true);
  }
}

// The law of count wall contacts into the batch's result arrays.
template <study::NormalModel N, study::RollingModel R, bool Shear>
[[gnu::always_inline]] inline void wallLaws(const study::ContactModel& model, const WallInputs& inputs, std::size_t count,
                                            double dt, double rolling_dt, WallBatch& out) {
  constexpr HistoryLayout L = HistoryLayout::of(N, R, Shear);
  const WallInputs in = inputs;  // the arrays in registers: the stores below do not reach them
  const study::ContactModel m = model;
  double *f0 = out.f[0].data(), *f1 = out.f[1].data(), *f2 = out.f[2].data();
  double *t0 = out.t[0].data(), *t1 = out.t[1].data(), *t2 = out.t[2].data();
  double* delta = out.delta.data();
  double* const hist[HistoryLayout::kMaxSize] = {out.hist[0].data(), out.hist[1].data(), out.hist[2].data(), out.hist[3].data(),
                                                 out.hist[4].data(), out.hist[5].data(), out.hist[6].data()};
  DEMFEM_INDEPENDENT_ITERATIONS
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t i = static_cast<std::size_t>(in.i[k]);
    const double normal[3] = {in.n0[k], in.n1[k], in.n2[k]};
    const double vwall[3] = {in.vw0[k], in.vw1[k], in.vw2[k]};
    ContactKinematics kin =
        contactKinematics<true>(normal, in.dist[k], in.radius[i], 0, &in.v[3 * i], &in.w[3 * i], vwall, nullptr);
    kin.wrel_norm = std::sqrt(norm2(kin.wrel));
    kin.inv_ii = in.inv_inertia[i];
    ContactHistory h = loadBatchHistory<L>(hist, k);
    const ContactResult res =
        contactForce<N, R, Shear>(m, in.laws[in.law[k]], in.stiffness[k], kin, dt, rolling_dt, in.cohesion[k], h, true);
    f0[k] = res.force[0];
    f1[k] = res.force[1];
    f2[k] = res.force[2];
    t0[k] = res.torque_i[0];
    t1[k] = res.torque_i[1];
    t2[k] = res.torque_i[2];
    delta[k] = kin.delta;
    storeBatchHistory<L>(h, hist, k);
  }
}

}  // namespace

void WallBatch::growTo(std::size_t contacts) {
  if (i.size() >= contacts) return;
  i.resize(contacts);
  law.resize(contacts);
  stiffness.resize(contacts);
  for (auto* a : {&dist, &cohesion, &delta}) a->resize(contacts);
  for (auto* a : {n, vwall, f, t})
    for (int c = 0; c < 3; ++c) a[c].resize(contacts);
  for (auto& h : hist) h.resize(contacts);
}

int DemSimulation::planeTouches(std::size_t i, WallTouch* touch, int nt) const {
  if (!near_plane_[i]) return nt;
  const double* xi = &x_[3 * i];
  for (int p = 0; p < static_cast<int>(planes_.size()); ++p) {
    const auto& pl = planes_[p];
    const double dist = pl.distance(xi);
    if (dist >= radius_[i] || nt == kMaxWallCandidates) continue;
    touch[nt++] = WallTouch{p, 0, FeatureKind::Face, {xi[0] - dist * pl.normal[0], xi[1] - dist * pl.normal[1], xi[2] - dist * pl.normal[2]},
                            pl.normal, dist, {-1, -1, -1}, {0, 0, 0}};
  }
  return nt;
}

int DemSimulation::meshTouches(std::size_t i, WallTouch* touch, int nt) const {
  const Vec3 xi{x_[3 * i], x_[3 * i + 1], x_[3 * i + 2]};
  const double ri = radius_[i];
  const int P = static_cast<int>(planes_.size());
  for (std::int32_t c = wc_start_[i]; c < wc_start_[i + 1] && nt < kMaxWallCandidates; ++c) {
    const int m = wc_mesh_[c];
    DEMFEM_ASSERT(m >= 0 && static_cast<std::size_t>(m) < meshes_.size() && wc_tri_[c] >= 0 &&
                  static_cast<std::size_t>(wc_tri_[c]) < meshes_[m].triangles.size());
    const auto& tri = meshes_[m].triangles[wc_tri_[c]];
    const auto& nodes = mesh_bin_nodes_[m];
    const ClosestFeature f = closestFeature(xi, nodes[tri[0]], nodes[tri[1]], nodes[tri[2]], tri, wc_tri_[c]);
    const double d[3] = {xi[0] - f.point[0], xi[1] - f.point[1], xi[2] - f.point[2]};
    const double d2 = norm2(d);
    if (d2 >= ri * ri) continue;
    const double dist = std::sqrt(d2);
    // A centre exactly on the surface takes the face normal.
    const Vec3 normal = dist > 0 ? Vec3{d[0] / dist, d[1] / dist, d[2] / dist}
                                 : faceNormal(nodes[tri[0]], nodes[tri[1]], nodes[tri[2]]);
    touch[nt++] = WallTouch{P + m, f.key, f.kind, f.point, normal, dist, {tri[0], tri[1], tri[2]},
                            {f.weights[0], f.weights[1], f.weights[2]}};
  }
  return nt;
}

// History hand-over: an accepted touch continues the last step's contact of the same (wall,
// feature), or else inherits the history of the one contact of the same wall that vanished in this
// step when it is the one new contact of that wall (the particle slid onto a neighbouring feature).
void DemSimulation::matchHistory(const WallContact* old, int n_old, const WallTouch* touch, int nt,
                                 const bool* accepted, int* matched_old) {
  for (int a = 0; a < nt; ++a) {
    matched_old[a] = -1;
    if (!accepted[a]) continue;
    for (int o = 0; o < n_old; ++o)
      if (old[o].wall == touch[a].wall && old[o].key == touch[a].key) matched_old[a] = o;
  }
  for (int a = 0; a < nt; ++a) {
    if (!accepted[a] || matched_old[a] >= 0) continue;
    int vanished = -1, count = 0;
    for (int o = 0; o < n_old; ++o) {
      if (old[o].wall != touch[a].wall) continue;
      bool still = false;
      for (int b = 0; b < nt; ++b) still = still || (accepted[b] && matched_old[b] == o);
      if (!still) {
        vanished = o;
        ++count;
      }
    }
    int fresh = 0;
    for (int b = 0; b < nt; ++b) fresh += accepted[b] && matched_old[b] < 0 && touch[b].wall == touch[a].wall;
    if (count == 1 && fresh == 1) matched_old[a] = vanished;
  }
}

int DemSimulation::wallMaterial(int wall) const {
  const int P = static_cast<int>(planes_.size());
  return wall >= P ? meshes_[wall - P].material : planes_[wall].material;
}

// The contact of a touch before its force: history and stiffness from the matched old contact, or
// fresh (zero history, the stiffness of the particle-wall pair).
DemSimulation::WallContact DemSimulation::openWallContact(std::size_t i, const WallTouch& t,
                                                          const WallContact* matched_old) const {
  WallContact wc{};
  wc.particle = static_cast<std::int32_t>(i);
  wc.wall = t.wall;
  wc.key = t.key;
  if (matched_old) {
    std::memcpy(wc.hist, matched_old->hist, sizeof(wc.hist));
    wc.stiffness = matched_old->stiffness;
  } else {
    wc.stiffness = wallStiffness(static_cast<int>(i), wallMaterial(t.wall));
  }
  for (int q = 0; q < 3; ++q) {
    wc.nodes[q] = t.nodes[q];
    wc.weights[q] = t.weights[q];
  }
  return wc;
}

// Velocity of the wall at the contact point: a mesh's rigid velocity plus its nodes' deformation
// velocities by the barycentric weights; a plane is at rest.
Vec3 DemSimulation::wallVelocity(const WallTouch& t) const {
  const int P = static_cast<int>(planes_.size());
  Vec3 v{0, 0, 0};
  if (t.wall < P) return v;
  const auto& mesh = meshes_[t.wall - P];
  for (int c = 0; c < 3; ++c) {
    v[c] = mesh.velocity[c];
    for (int q = 0; q < 3; ++q) v[c] += t.weights[q] * mesh.deformation_velocity[t.nodes[q]][c];
  }
  return v;
}

void DemSimulation::wallForces(int part) {
  withModel(model_, [&]<study::NormalModel N, study::RollingModel R, bool Shear>() { wallLoop<N, R, Shear>(part); });
}

// The wall contacts of this part's particles, in particle order, into its own list (the next
// step's old contacts); the forces go to the particles batch by batch, the reactions to the walls
// after the phase (serial, scatterWallForces).
template <study::NormalModel N, study::RollingModel R, bool Shear>
void DemSimulation::wallLoop(int part) {
  PartState& ts = part_[part];
  const std::size_t lo = rangeBegin(part), hi = rangeEnd(part);
  const bool have_old = ts.wall_start.size() == hi - lo + 1;
  auto& out = ts.wall_next;
  out.clear();
  ts.wall_start_next.resize(hi - lo + 1);
  ts.wall_batch.growTo(kWallBatchContacts + kMaxWallCandidates);
  ts.wall_max = 0;
  ts.wall_bad = -1;
  ts.plane_force.assign(planes_.size(), Vec3{0, 0, 0});
  ts.mesh_shares.clear();
  // Contacts in the batch (out's last ones) and in out, counted here rather than read back from
  // out after each particle (for the reason in queueWallContact).
  std::size_t count = 0, size = 0;
  for (std::size_t i = lo; i < hi; ++i) {
    ts.wall_start_next[i - lo] = static_cast<std::int32_t>(size);
    const bool near_mesh = wc_start_[i] != wc_start_[i + 1];
    if (!near_plane_[i] && !near_mesh) continue;  // most particles: no wall within reach
    const WallContact* old = have_old ? ts.wall.data() + ts.wall_start[i - lo] : nullptr;
    const int n_old = have_old ? ts.wall_start[i - lo + 1] - ts.wall_start[i - lo] : 0;
    const std::size_t queued = near_mesh ? queueWallContacts(i, old, n_old, out, ts.wall_batch, count)
                                         : queuePlaneContacts(i, old, n_old, out, ts.wall_batch, count);
    size += queued - count;
    count = queued;
    if (count >= kWallBatchContacts) {
      wallBatchForces<N, R, Shear>(ts, count, out.data() + (size - count), ts.wall_max);
      count = 0;
    }
  }
  DEMFEM_ASSERT(size == out.size());
  if (count > 0) wallBatchForces<N, R, Shear>(ts, count, out.data() + (size - count), ts.wall_max);
  ts.wall_start_next[hi - lo] = static_cast<std::int32_t>(size);
  ts.wall.swap(ts.wall_next);
  ts.wall_start.swap(ts.wall_start_next);
}

// A contact of particle i with wall `wall` at batch place `k`: the law's inputs, the stiffness and
// history read from where they come from (the last step's contact, or a new contact's) rather than
// back from the WallContact just appended to out: loads of memory stored a moment before are what
// the wall loop waited on, once per contact and step (docs/builtin-dem.md, "The wall loop's stores").
void DemSimulation::queueWallContact(std::size_t i, int wall, const ContactStiffness& stiffness, const double* hist,
                                     const Vec3& normal, double dist, const Vec3& vwall, WallBatch& b, std::size_t k) const {
  b.i[k] = static_cast<std::int32_t>(i);
  b.law[k] = material_[i] * static_cast<std::int32_t>(table_.materials.size()) + wallMaterial(wall);
  b.stiffness[k] = stiffness;
  b.dist[k] = dist;
  for (int c = 0; c < 3; ++c) {
    b.n[c][k] = normal[c];
    b.vwall[c][k] = vwall[c];
  }
  for (int h = 0; h < layout_.size; ++h) b.hist[h][k] = hist[h];
}

// The contacts of particle i with every wall feature in reach (fine search, de-duplication,
// history hand-over) into out and the batch from place `count`; returns the new count.
std::size_t DemSimulation::queueWallContacts(std::size_t i, const WallContact* old, int n_old, WallContacts& out,
                                             WallBatch& b, std::size_t count) const {
  WallTouch touch[kMaxWallCandidates];
  bool accepted[kMaxWallCandidates] = {};  // filled by acceptDistinct (initialised: GCC cannot see it)
  int matched_old[kMaxWallCandidates];
  const int nt = meshTouches(i, touch, planeTouches(i, touch, 0));
  DEMFEM_ASSERT(nt >= 0 && nt <= kMaxWallCandidates);
  if (nt == 0) return count;
  acceptDistinct(touch, nt, static_cast<int>(planes_.size()), radius_[i], accepted);
  matchHistory(old, n_old, touch, nt, accepted, matched_old);
  for (int a = 0; a < nt; ++a) {
    if (!accepted[a]) continue;
    const WallContact* last = matched_old[a] >= 0 ? old + matched_old[a] : nullptr;
    const WallContact& wc = out.emplace_back(openWallContact(i, touch[a], last));
    queueWallContact(i, touch[a].wall, last ? last->stiffness : wc.stiffness, last ? last->hist : kNoHistory, touch[a].normal,
                     touch[a].dist, wallVelocity(touch[a]), b, count++);
  }
  return count;
}

// queueWallContacts for a particle with planes only in reach, without its general steps: planes
// are distinct contacts in plane order, at rest, and a plane's contact continues the particle's
// last contact with that plane or is new (the steps above give the same).
std::size_t DemSimulation::queuePlaneContacts(std::size_t i, const WallContact* old, int n_old, WallContacts& out,
                                              WallBatch& b, std::size_t count) const {
  const double* xi = &x_[3 * i];
  int touching = 0;
  for (int p = 0; p < static_cast<int>(planes_.size()) && touching < kMaxWallCandidates; ++p) {
    const auto& pl = planes_[p];
    const double dist = pl.distance(xi);
    if (dist >= radius_[i]) continue;
    ++touching;
    const WallContact* last = nullptr;
    for (int o = 0; o < n_old; ++o)
      if (old[o].wall == p) last = old + o;
    const ContactStiffness fresh = last ? ContactStiffness{} : wallStiffness(static_cast<int>(i), pl.material);
    const ContactStiffness& stiffness = last ? last->stiffness : fresh;
    const double* const hist = last ? last->hist : kNoHistory;
    queueWallContact(i, p, stiffness, hist, pl.normal, dist, Vec3{0, 0, 0}, b, count++);
    WallContact& wc = out.emplace_back();  // uninitialised: every field is written here
    wc.particle = static_cast<std::int32_t>(i);
    wc.wall = p;
    wc.key = 0;
    std::memcpy(wc.hist, hist, sizeof(wc.hist));
    wc.stiffness = stiffness;
    wc.nodes[0] = wc.nodes[1] = wc.nodes[2] = -1;
    wc.padding = 0;
    for (int c = 0; c < 3; ++c) wc.weights[c] = wc.force[c] = 0;
  }
  return count;
}

template <study::NormalModel N, study::RollingModel R, bool Shear>
void DemSimulation::wallBatchForces(PartState& part, std::size_t count, WallContact* contacts, double& max_overlap) {
  constexpr HistoryLayout L = HistoryLayout::of(N, R, Shear);
  WallBatch& b = part.wall_batch;
  const WallInputs in{v_.data(),          w_.data(),          radius_.data(),     inv_inertia_.data(), table_.laws.data(),
                      b.i.data(),         b.law.data(),       b.stiffness.data(), b.n[0].data(),       b.n[1].data(),
                      b.n[2].data(),      b.dist.data(),      b.vwall[0].data(),  b.vwall[1].data(),   b.vwall[2].data(),
                      b.cohesion.data()};
  withCohesion(model_.cohesion, [&]<study::CohesionModel C>() {
    runVectorised([&]() DEMFEM_INLINE { wallCohesion<C>(in, count, b.cohesion.data()); });
  });
  const double rolling_dt = rollingStep();
  runVectorised([&]() DEMFEM_INLINE { wallLaws<N, R, Shear>(model_, in, count, dt_, rolling_dt, b); });
  // In contact order: each particle's forces are added as one contact after the other would.
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t i = static_cast<std::size_t>(b.i[k]);
    WallContact& wc = contacts[k];
    const double delta = b.delta[k];
    if (delta > max_overlap) max_overlap = delta;
    if (delta > overlapLimitFraction() * radius_[i] && part.wall_bad < 0) {
      part.wall_bad = static_cast<std::int64_t>(i);
      part.wall_bad_wall = wc.wall;
    }
    for (int h = 0; h < L.size; ++h) wc.hist[h] = b.hist[h][k];
    const double force[3] = {b.f[0][k], b.f[1][k], b.f[2][k]}, torque[3] = {b.t[0][k], b.t[1][k], b.t[2][k]};
    for (int c = 0; c < 3; ++c) {
      f_[3 * i + c] += force[c];
      t_[3 * i + c] += torque[c];
      wc.force[c] = force[c];
    }
    keepWallReaction(part, wc, force);
  }
}

void DemSimulation::dropWallContacts() {
  for (auto& part : part_) {
    part.wall.clear();
    part.wall_start.clear();
  }
}

// Reactions on the walls: the force on each plane, and on each mesh node its barycentric share of
// every contact (force of this step, impulse accumulated over dt).
// In the part's phase, so that the calling thread does not read every wall contact of every part
// between the phases (serial work, and memory written on another core). A node's shares are the
// terms the caller once added contact by contact, in the same order, so the node forces are those
// of that sum bit for bit; a plane's force is the sum of the parts' sums (with 2 or more threads,
// another order than contact by contact: it differs at round-off, and no particle feels it).
void DemSimulation::keepWallReaction(PartState& part, const WallContact& wc, const double* force) const {
  const int P = static_cast<int>(planes_.size());
  if (wc.wall < P) {
    for (int c = 0; c < 3; ++c) part.plane_force[static_cast<std::size_t>(wc.wall)][c] -= force[c];
    return;
  }
  for (int q = 0; q < 3; ++q) {
    if (wc.weights[q] == 0) continue;
    MeshShare& share = part.mesh_shares.emplace_back();
    share.mesh = wc.wall - P;
    share.node = wc.nodes[q];
    for (int c = 0; c < 3; ++c) share.force[c] = -force[c] * wc.weights[q];
  }
}

void DemSimulation::scatterWallForces() {
  for (std::size_t p = 0; p < planes_.size(); ++p) {
    plane_force_[p] = part_.front().plane_force[p];
    for (std::size_t k = 1; k < part_.size(); ++k)
      for (int c = 0; c < 3; ++c) plane_force_[p][c] += part_[k].plane_force[p][c];
  }
  for (auto& mf : mesh_force_) std::fill(mf.begin(), mf.end(), 0.0);
  for (const auto& part : part_)  // in particle order: the parts' ranges ascend
    for (const auto& share : part.mesh_shares) {
      auto& mf = mesh_force_[static_cast<std::size_t>(share.mesh)];
      auto& mi = mesh_impulse_[static_cast<std::size_t>(share.mesh)];
      DEMFEM_ASSERT(share.node >= 0 && 3 * static_cast<std::size_t>(share.node) < mf.size());
      for (int c = 0; c < 3; ++c) {
        mf[3 * share.node + c] += share.force[c];
        mi[3 * share.node + c] += share.force[c] * dt_;
      }
    }
}

}  // namespace demfem::builtin

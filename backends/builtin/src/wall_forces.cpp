// Particle-wall contact forces of the built-in DEM (docs/builtin-dem.md, "Mesh contacts without
// double counting"), in the steps of a contact search: the broad search (the candidates of the list
// build, neighbour_lists.cpp) is narrowed per particle to the wall features it touches (fine
// search), features reached through several triangles become one contact, each contact takes its
// history over from the last step, and the law's force is split to the mesh nodes.
#include "demfem/backends/builtin/simulation.hpp"

#include "demfem/backends/physics/dem_assert.hpp"

#include "contact_kinematics.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <tuple>

namespace demfem::builtin {

using detail::norm2;

namespace {
constexpr int kMaxWallCandidates = 32;  // touching features per particle before de-duplication
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

}  // namespace

int DemSimulation::planeTouches(std::size_t i, WallTouch* touch, int nt) const {
  if (!near_plane_[i]) return nt;
  const double* xi = &x_[3 * i];
  for (int p = 0; p < static_cast<int>(planes_.size()); ++p) {
    const auto& pl = planes_[p];
    const double dist = (xi[0] - pl.point[0]) * pl.normal[0] + (xi[1] - pl.point[1]) * pl.normal[1] +
                        (xi[2] - pl.point[2]) * pl.normal[2];
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
// step's old contacts); the forces go to the particles at once, the reactions to the walls after
// the phase (serial, scatterWallForces).
template <study::NormalModel N, study::RollingModel R, bool Shear>
void DemSimulation::wallLoop(int part) {
  PartState& ts = part_[part];
  const std::size_t lo = rangeBegin(part), hi = rangeEnd(part);
  const bool have_old = ts.wall_start.size() == hi - lo + 1;
  auto& out = ts.wall_next;
  out.clear();
  ts.wall_start_next.resize(hi - lo + 1);
  double local_max = 0;
  std::int64_t bad = -1;
  WallTouch touch[kMaxWallCandidates];
  bool accepted[kMaxWallCandidates];
  int matched_old[kMaxWallCandidates];
  for (std::size_t i = lo; i < hi; ++i) {
    ts.wall_start_next[i - lo] = static_cast<std::int32_t>(out.size());
    if (!near_plane_[i] && wc_start_[i] == wc_start_[i + 1]) continue;  // most particles: no wall within reach
    const int nt = meshTouches(i, touch, planeTouches(i, touch, 0));
    DEMFEM_ASSERT(nt >= 0 && nt <= kMaxWallCandidates);
    if (nt == 0) continue;
    acceptDistinct(touch, nt, static_cast<int>(planes_.size()), radius_[i], accepted);
    const WallContact* old = have_old ? ts.wall.data() + ts.wall_start[i - lo] : nullptr;
    const int n_old = have_old ? ts.wall_start[i - lo + 1] - ts.wall_start[i - lo] : 0;
    matchHistory(old, n_old, touch, nt, accepted, matched_old);
    for (int a = 0; a < nt; ++a) {
      if (!accepted[a]) continue;
      WallContact wc = openWallContact(i, touch[a], matched_old[a] >= 0 ? old + matched_old[a] : nullptr);
      const Vec3 vwall = wallVelocity(touch[a]);
      ContactKinematics k = contactKinematics<true>(touch[a].normal.data(), touch[a].dist, radius_[i], 0,
                                                    &v_[3 * i], &w_[3 * i], vwall.data(), nullptr);
      k.wrel_norm = std::sqrt(norm2(k.wrel));
      k.inv_ii = inv_inertia_[i];
      if (k.delta > local_max) local_max = k.delta;
      if (k.delta > overlapLimitFraction() * radius_[i] && bad < 0) {
        bad = static_cast<std::int64_t>(i);
        ts.wall_bad_wall = touch[a].wall;
      }
      const PairLaw& law = table_.law(material_[i], wallMaterial(touch[a].wall));
      ContactHistory hist = loadHistory(layout_, wc.hist);
      const ContactResult res = contactForce<N, R, Shear>(model_, law, wc.stiffness, k, dt_, rollingStep(),
                                                          cohesionForce(model_.cohesion, law, k, true), hist, true);
      storeHistory(layout_, hist, wc.hist);
      for (int c = 0; c < 3; ++c) {
        f_[3 * i + c] += res.force[c];
        t_[3 * i + c] += res.torque_i[c];
        wc.force[c] = res.force[c];
      }
      out.push_back(wc);
    }
  }
  ts.wall_start_next[hi - lo] = static_cast<std::int32_t>(out.size());
  ts.wall.swap(ts.wall_next);
  ts.wall_start.swap(ts.wall_start_next);
  ts.wall_max = local_max;
  ts.wall_bad = bad;
}

void DemSimulation::dropWallContacts() {
  for (auto& part : part_) {
    part.wall.clear();
    part.wall_start.clear();
  }
}

// Reactions on the walls: the force on each plane, and on each mesh node its barycentric share of
// every contact (force of this step, impulse accumulated over dt).
void DemSimulation::scatterWallForces() {
  const int P = static_cast<int>(planes_.size());
  for (auto& mf : mesh_force_) std::fill(mf.begin(), mf.end(), 0.0);
  for (auto& pf : plane_force_) pf = {0, 0, 0};
  for (const auto& part : part_)  // in particle order: the parts' ranges ascend
    for (const auto& wc : part.wall) {
      if (wc.wall < P) {
        for (int c = 0; c < 3; ++c) plane_force_[wc.wall][c] -= wc.force[c];
        continue;
      }
      auto& mf = mesh_force_[wc.wall - P];
      auto& mi = mesh_impulse_[wc.wall - P];
      for (int q = 0; q < 3; ++q) {
        if (wc.weights[q] == 0) continue;
        DEMFEM_ASSERT(wc.nodes[q] >= 0 && 3 * static_cast<std::size_t>(wc.nodes[q]) < mf.size());
        for (int c = 0; c < 3; ++c) {
          const double f = -wc.force[c] * wc.weights[q];
          mf[3 * wc.nodes[q] + c] += f;
          mi[3 * wc.nodes[q] + c] += f * dt_;
        }
      }
    }
}

}  // namespace demfem::builtin

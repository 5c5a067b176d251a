// Bit-exact state of the built-in DEM: save, restore with checks of everything a checkpoint file
// can hold (docs/builtin-dem.md, "Performance design").
#include "demfem/backends/builtin/simulation.hpp"

#include "demfem/backends/physics/dem_assert.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <stdexcept>

namespace demfem::builtin {


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
  if (damping_per_s_ != 0) throw std::logic_error("builtin DEM: saveState() with settling damping on (a deposition is never saved)");
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
  out.putVector(part_window_end_);
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
  const WallContactList wall = wallContactList();
  out.putVector(wall.contacts);
  out.putVector(wall.start);
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
  s.list_min_radius_ = s.radius_.empty() ? 0.0 : *std::min_element(s.radius_.begin(), s.radius_.end());
  in.getVector(s.material_);
  in.getVector(s.layer_);
  in.getVector(s.used_);
  in.getVector(s.nb_start_);
  in.getVector(s.nb_j_);
  in.getVector(s.nb_stiff_);
  in.getVector(s.nb_hist_);
  in.getVector(s.nb_touch_);
  in.getVector(s.part_window_end_);
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
  WallContactList wall;
  in.getVector(wall.contacts);
  in.getVector(wall.start);
  in.getVector(s.plane_force_);
  s.checkRestoredAgainst(*this, wall, in);
  s.nb_i_.resize(s.nb_j_.size());
  for (std::size_t i = 0; i + 1 < s.nb_start_.size(); ++i)
    std::fill(s.nb_i_.begin() + s.nb_start_[i], s.nb_i_.begin() + s.nb_start_[i + 1], static_cast<std::int32_t>(i));
  s.setWallContacts(wall);
  s.updateMeshBinNodes();
  return s;
}

// What the study fixes must equal the live simulation's; what evolves must be finite, sized to
// the particles and meshes, and index only what exists. Nothing a corrupted but checksummed file
// holds can then make a later step read out of bounds.
void DemSimulation::checkRestoredAgainst(const DemSimulation& live, const WallContactList& wall,
                                         const adapter::PayloadReader& in) const {
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
  // Each part's window end is what its rows imply (fillNextList): a wrong one lets a part write
  // forces where another part writes them, or past its buffer.
  require(part_window_end_.empty() || part_window_end_.size() == static_cast<std::size_t>(threads_),
          "part windows have the wrong count");
  require(!lists_valid_ || !part_window_end_.empty(), "part windows missing");
  for (int p = 0; p < static_cast<int>(part_window_end_.size()); ++p) {
    std::size_t end = rangeEnd(p);
    for (std::size_t i = rangeBegin(p); i < rangeEnd(p) && i + 1 < nb_start_.size(); ++i)
      if (nb_start_[i + 1] > nb_start_[i]) end = std::max(end, static_cast<std::size_t>(nb_j_[nb_start_[i + 1] - 1]) + 1);
    require(part_window_end_[p] == end, "a part window differs from what its neighbour rows reach");
  }
  // Wall candidates and contacts.
  require(isOffsets(wc_start_, n, wc_mesh_.size()) && wc_tri_.size() == wc_mesh_.size() &&
              (!lists_valid_ || (wc_start_.size() == n + 1 && near_plane_.size() == n)) &&
              (near_plane_.empty() || near_plane_.size() == n),
          "wall candidate lists are inconsistent");
  for (std::size_t c = 0; c < wc_mesh_.size(); ++c)
    require(wc_mesh_[c] >= 0 && static_cast<std::size_t>(wc_mesh_[c]) < meshes_.size() && wc_tri_[c] >= 0 &&
                static_cast<std::size_t>(wc_tri_[c]) < meshes_[wc_mesh_[c]].triangles.size(),
            "a wall candidate names a mesh or triangle that does not exist");
  require(isOffsets(wall.start, n, wall.contacts.size()) && (!wall.start.empty() || wall.contacts.empty()),
          "wall contact offsets are inconsistent");
  const std::size_t walls = planes_.size() + meshes_.size();
  for (std::size_t c = 0; c < wall.contacts.size(); ++c) {
    const WallContact& wc = wall.contacts[c];
    require(wc.particle >= 0 && static_cast<std::size_t>(wc.particle) < n && wc.wall >= 0 &&
                static_cast<std::size_t>(wc.wall) < walls && (c == 0 || wall.contacts[c - 1].particle <= wc.particle),
            "a wall contact names a particle or wall that does not exist");
    require(wall.start.empty() || (static_cast<std::size_t>(wall.start[wc.particle]) <= c &&
                                   c < static_cast<std::size_t>(wall.start[wc.particle + 1])),
            "a wall contact lies outside its particle's row");
    if (static_cast<std::size_t>(wc.wall) >= planes_.size())
      for (const auto node : wc.nodes)
        require(node >= 0 && static_cast<std::size_t>(node) < meshes_[wc.wall - planes_.size()].nodes.size(),
                "a wall contact names a mesh node that does not exist");
  }
}

void DemSimulation::loadState(adapter::PayloadReader& in) { *this = withState(in); }

DemSimulation::WallContactList DemSimulation::wallContactList() const {
  WallContactList list;
  const bool found = std::all_of(part_.begin(), part_.end(), [](const PartState& p) { return !p.wall_start.empty(); });
  if (!found) return list;  // before the first force evaluation (or after particles changed)
  list.start.reserve(particleCount() + 1);
  for (int p = 0; p < threads_; ++p) {
    const auto offset = static_cast<std::int32_t>(list.contacts.size());
    const auto& start = part_[p].wall_start;
    DEMFEM_ASSERT(start.size() == rangeEnd(p) - rangeBegin(p) + 1);
    for (std::size_t k = 0; k + 1 < start.size(); ++k) list.start.push_back(offset + start[k]);
    list.contacts.insert(list.contacts.end(), part_[p].wall.begin(), part_[p].wall.end());
  }
  list.start.push_back(static_cast<std::int32_t>(list.contacts.size()));
  return list;
}

void DemSimulation::setWallContacts(const WallContactList& list) {
  dropWallContacts();
  if (list.start.empty()) return;
  for (int p = 0; p < threads_; ++p) {
    PartState& part = part_[p];
    const std::size_t lo = rangeBegin(p), hi = rangeEnd(p);
    part.wall.assign(list.contacts.begin() + list.start[lo], list.contacts.begin() + list.start[hi]);
    for (std::size_t i = lo; i <= hi; ++i) part.wall_start.push_back(list.start[i] - list.start[lo]);
  }
}

}  // namespace demfem::builtin

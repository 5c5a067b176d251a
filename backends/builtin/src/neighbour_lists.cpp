// Neighbour lists of the built-in DEM (docs/builtin-dem.md, "Performance design"): linked cells,
// the half Verlet list of particle pairs with its per-slot stiffness and carried-over history, and
// the wall candidates (broad search) of every particle.
#include "demfem/backends/builtin/simulation.hpp"

#include "demfem/backends/physics/dem_assert.hpp"

#include <algorithm>
#include <cmath>
#include <tuple>

namespace demfem::builtin {

using detail::norm2;

// Clamped before the conversion: a wall node far outside the grid (a peer may place a mesh
// anywhere) or a non-finite one lands in an edge cell instead of overflowing the int.
int DemSimulation::CellGrid::cellOf(double c, int axis) const {
  const double k = std::floor((c - lo[axis]) / size);
  if (!(k > 0)) return 0;
  return static_cast<int>(std::min(k, static_cast<double>(n[axis] - 1)));
}

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

// The cells, the row offsets and the swap to the new list on the calling thread; the rows and the
// filling of the new list (slots, stiffness, carried-over history) as phases of the team, each part
// on its own particles: a list build's serial share is O(particles), not O(slots).
void DemSimulation::rebuildLists() {
  const std::size_t n = particleCount();
  buildCellGrid();
  team_.forEachPart([&](int part) { buildRows(part); });
  for (std::size_t i = 0; i < n; ++i) build_start_[i + 1] += build_start_[i];
  sizeNextLists();
  part_window_end_.assign(threads_, 0);
  team_.forEachPart([&](int part) { fillNextList(part); });
  nb_stiff_.swap(next_stiff_);
  nb_hist_.swap(next_hist_);
  nb_touch_.swap(next_touch_);
  nb_start_.swap(build_start_);
  nb_j_.swap(build_j_);
  nb_i_.swap(build_i_);
  DEMFEM_ASSERT(nb_start_.size() == n + 1 && nb_stiff_.size() == nb_j_.size() && nb_i_.size() == nb_j_.size());
  buildWallCandidates(grid_);
  x_build_ = x_;
  mesh_build_nodes_ = mesh_bin_nodes_;
  lists_valid_ = true;
}

// Cells of edge >= 2 rmax + skin over the particles' bounding box (within the domain).
void DemSimulation::buildCellGrid() {
  const std::size_t n = particleCount();
  const double rmin = n ? *std::min_element(radius_.begin(), radius_.end()) : 0.0;
  const double rmax = n ? *std::max_element(radius_.begin(), radius_.end()) : 0.0;
  if (skin_ == 0) skin_ = 0.2 * rmin;  // fixed at the first build (part of the saved state)
  list_min_radius_ = rmin;
  CellGrid& g = grid_;
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
  std::vector<std::int32_t> fill(g.start.begin(), g.start.end() - 1);
  for (std::size_t i = 0; i < n; ++i) g.items[fill[cell_of[i]]++] = static_cast<std::int32_t>(i);
  build_start_.assign(n + 1, 0);
}

// The sorted neighbours j > i within radius_i + radius_j + skin of the part's rows i; the row
// lengths go to build_start_[i + 1] (summed to offsets by rebuildLists).
void DemSimulation::buildRows(int part) {
  const CellGrid& g = grid_;
  auto& out = part_[part].rows;
  out.clear();
  std::vector<std::int32_t> row;
  for (std::size_t i = rangeBegin(part); i < rangeEnd(part); ++i) {
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
    build_start_[i + 1] = static_cast<std::int32_t>(row.size());
    out.insert(out.end(), row.begin(), row.end());
  }
}

// The new list's arrays at their size: every slot is written by fillNextList, so kept elements are
// not cleared (resize, not assign: no pass over the slots here).
void DemSimulation::sizeNextLists() {
  const std::size_t slots = static_cast<std::size_t>(build_start_[particleCount()]);
  build_j_.resize(slots);
  build_i_.resize(slots);
  next_stiff_.resize(slots);
  next_hist_.resize(slots * layout_.size);
  next_touch_.resize(slots);
}

// The part's rows placed at their offsets in the new list, with every slot's stiffness and its
// history: the old list's for a pair it had (rows sorted by j: one merge per row), zero for a new
// one. Also the part's window end: one past the highest particle its rows reach.
void DemSimulation::fillNextList(int part) {
  const std::size_t n = particleCount();
  const int H = layout_.size;
  const bool carry = nb_start_.size() == n + 1;
  const std::size_t lo = rangeBegin(part), hi = rangeEnd(part);
  const std::int32_t* const rows = part_[part].rows.data();
  const std::int32_t base = build_start_[lo];  // slot s is rows[s - base]
  std::size_t window_end = hi;
  for (std::size_t i = lo; i < hi; ++i) {
    std::int32_t o = carry ? nb_start_[i] : 0;
    const std::int32_t oend = carry ? nb_start_[i + 1] : 0;
    for (std::int32_t s = build_start_[i]; s < build_start_[i + 1]; ++s) {
      const std::int32_t j = rows[s - base];
      DEMFEM_ASSERT(static_cast<std::size_t>(j) > i && static_cast<std::size_t>(j) < n && (s == build_start_[i] || build_j_[s - 1] < j));
      build_j_[s] = j;
      build_i_[s] = static_cast<std::int32_t>(i);
      window_end = std::max(window_end, static_cast<std::size_t>(j) + 1);
      const double ri = radius_[i], rj = radius_[j];
      const double mi = mass_[i], mj = mass_[j];
      next_stiff_[s] = contactStiffness(model_, table_.law(material_[i], material_[j]), ri * rj / (ri + rj), mi * mj / (mi + mj));
      while (o < oend && nb_j_[o] < j) ++o;
      const bool had = o < oend && nb_j_[o] == j;
      next_touch_[s] = had ? nb_touch_[o] : 0;
      double* const h = &next_hist_[static_cast<std::size_t>(s) * H];
      for (int k = 0; k < H; ++k) h[k] = had ? nb_hist_[static_cast<std::size_t>(o) * H + k] : 0.0;
    }
  }
  part_window_end_[part] = window_end;
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
    DEMFEM_ASSERT(cands[c].particle >= 0 && static_cast<std::size_t>(cands[c].particle) < n);
    ++wc_start_[cands[c].particle + 1];
    wc_mesh_[c] = cands[c].mesh;
    wc_tri_[c] = cands[c].tri;
  }
  for (std::size_t i = 0; i < n; ++i) wc_start_[i + 1] += wc_start_[i];
  // Plane walls: only particles within radius + skin of one can touch it before the next build.
  near_plane_.assign(n, 0);
  for (std::size_t i = 0; i < n; ++i)
    for (const auto& pl : planes_) {
      if (pl.distance(&x_[3 * i]) < radius_[i] + skin_) near_plane_[i] = 1;
    }
}

}  // namespace demfem::builtin

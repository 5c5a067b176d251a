#include "demfem/adapter/plate_surface.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace demfem::adapter {

std::int32_t PlateSurface::id(int i, int j, int k) const {
  if (i < 0 || j < 0 || k < 0 || i >= nx || j >= ny || k >= nz) return -1;
  return index_[(static_cast<std::size_t>(k) * ny + j) * nx + i];
}

namespace {

int intervals(double edge, double spacing) {
  return std::max(1, static_cast<int>(std::lround(edge / spacing)));
}

// Adds the two triangles of quad (a, b, c, d), given counter-clockwise seen from outside.
void addQuad(PlateSurface& s, std::int32_t a, std::int32_t b, std::int32_t c, std::int32_t d) {
  s.triangles.push_back({a, b, c});
  s.triangles.push_back({a, c, d});
}

}  // namespace

PlateSurface makePlateSurface(double length, double width, double thickness, double spacing) {
  if (!(length > 0) || !(width > 0) || !(thickness > 0) || !(spacing > 0)) {
    throw std::invalid_argument("plate surface: length, width, thickness and spacing must be > 0 (got " +
                                std::to_string(length) + ", " + std::to_string(width) + ", " +
                                std::to_string(thickness) + ", " + std::to_string(spacing) + " m)");
  }
  PlateSurface s;
  s.nx = intervals(width, spacing) + 1;
  s.ny = intervals(length, spacing) + 1;
  s.nz = intervals(thickness, spacing) + 1;
  s.index_.assign(static_cast<std::size_t>(s.nx) * s.ny * s.nz, -1);
  for (int k = 0; k < s.nz; ++k) {
    for (int j = 0; j < s.ny; ++j) {
      for (int i = 0; i < s.nx; ++i) {
        const bool surface = i == 0 || j == 0 || k == 0 || i == s.nx - 1 || j == s.ny - 1 || k == s.nz - 1;
        if (!surface) continue;
        s.index_[(static_cast<std::size_t>(k) * s.ny + j) * s.nx + i] = static_cast<std::int32_t>(s.nodes.size());
        s.nodes.push_back({-width / 2 + width * i / (s.nx - 1), length * j / (s.ny - 1),
                           -thickness / 2 + thickness * k / (s.nz - 1)});
        s.grid_index.push_back({i, j, k});
      }
    }
  }
  const int X = s.nx - 1, Y = s.ny - 1, Z = s.nz - 1;
  // z faces: front (k = Z, normal +z) and back (k = 0, normal -z).
  for (int j = 0; j < Y; ++j)
    for (int i = 0; i < X; ++i) {
      addQuad(s, s.id(i, j, Z), s.id(i + 1, j, Z), s.id(i + 1, j + 1, Z), s.id(i, j + 1, Z));
      addQuad(s, s.id(i, j, 0), s.id(i, j + 1, 0), s.id(i + 1, j + 1, 0), s.id(i + 1, j, 0));
    }
  // x faces: i = X (normal +x) and i = 0 (normal -x).
  for (int k = 0; k < Z; ++k)
    for (int j = 0; j < Y; ++j) {
      addQuad(s, s.id(X, j, k), s.id(X, j + 1, k), s.id(X, j + 1, k + 1), s.id(X, j, k + 1));
      addQuad(s, s.id(0, j, k), s.id(0, j, k + 1), s.id(0, j + 1, k + 1), s.id(0, j + 1, k));
    }
  // y faces: top j = Y (normal +y) and tip j = 0 (normal -y).
  for (int k = 0; k < Z; ++k)
    for (int i = 0; i < X; ++i) {
      addQuad(s, s.id(i, Y, k), s.id(i, Y, k + 1), s.id(i + 1, Y, k + 1), s.id(i + 1, Y, k));
      addQuad(s, s.id(i, 0, k), s.id(i + 1, 0, k), s.id(i + 1, 0, k + 1), s.id(i, 0, k + 1));
    }
  return s;
}

}  // namespace demfem::adapter

// Small soils built in code for the builtin DEM tests (support/grain_soil.hpp: one particle material
// "grain" and one wall material "steel"), their box, particle masses and a flat mesh.
#pragma once

#include "demfem/backends/builtin/simulation.hpp"
#include "demfem/study/study.hpp"
#include "support/grain_soil.hpp"

#include <numbers>

namespace demfem::builtin::testing {

using support::makeSoil;  // support/grain_soil.hpp
using support::SoilParameters;

inline Domain box(double half) { return Domain{{-half, -half, -half}, {half, half, half}}; }

inline double sphereMass(double density, double radius) {
  return density * 4.0 / 3.0 * std::numbers::pi * radius * radius * radius;
}

// A flat square mesh in the plane y = 0 (normal +y), (n+1) x (n+1) nodes over [-h, h]^2 in x and z,
// each square split along its diagonal.
inline TriangleMesh flatMesh(double h, int n) {
  TriangleMesh mesh;
  mesh.name = "flat";
  for (int k = 0; k <= n; ++k)
    for (int i = 0; i <= n; ++i) mesh.rest_nodes.push_back({-h + 2 * h * i / n, 0.0, -h + 2 * h * k / n});
  const auto id = [n](int i, int k) { return static_cast<std::int32_t>(k * (n + 1) + i); };
  for (int k = 0; k < n; ++k)
    for (int i = 0; i < n; ++i) {
      // counter-clockwise seen from +y: (i,k) -> (i,k+1) -> (i+1,k+1)
      mesh.triangles.push_back({id(i, k), id(i, k + 1), id(i + 1, k + 1)});
      mesh.triangles.push_back({id(i, k), id(i + 1, k + 1), id(i + 1, k)});
    }
  mesh.nodes = mesh.rest_nodes;
  return mesh;
}

}  // namespace demfem::builtin::testing

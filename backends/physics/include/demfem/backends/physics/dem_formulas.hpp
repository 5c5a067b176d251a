// The DEM formulas both backends use, in one place (docs/architecture.md section 11): the Rayleigh
// time step, LIGGGHTS' hooke stiffness and the closest point of a triangle to a sphere centre.
//
// Contract
// - SI units; pure functions of their arguments (inline, no allocation, no state).
// - rayleighTimeStep: pi R sqrt(rho / G) / (0.1631 nu + 0.8766), G = E / (2 (1 + nu)), for a sphere
//   of radius R (the caller picks the smallest one it simulates).
// - effectiveYoungs: Y* = 1 / ((1 - nu_i^2) / Y_i + (1 - nu_j^2) / Y_j).
// - hookeNormalStiffness: LIGGGHTS 3.8 normal_model_hooke, kn = 16/15 sqrt(R*) Y* (15 m* v_c^2 /
//   (16 sqrt(R*) Y*))^(1/5), with R* and m* the effective radius and mass (a wall contact: the
//   particle's own).
// - closestOnTriangle: the Voronoi region of triangle (a, b, c) that holds the point nearest to p
//   (a vertex, an edge, the face; Ericson, Real-Time Collision Detection, 5.1.5) and the barycentric
//   weights of that point (non-negative, sum 1; zero for the nodes off the region). A point exactly
//   on an edge is reported as that edge, never as the face.
#pragma once

#include <array>
#include <cmath>
#include <numbers>

namespace demfem::physics {

using Point3 = std::array<double, 3>;

inline double rayleighTimeStep(double radius_m, double density_kg_m3, double youngs_Pa, double poisson) {
  const double shear_modulus = youngs_Pa / (2 * (1 + poisson));
  return std::numbers::pi * radius_m * std::sqrt(density_kg_m3 / shear_modulus) / (0.1631 * poisson + 0.8766);
}

inline double effectiveYoungs(double youngs_i_Pa, double poisson_i, double youngs_j_Pa, double poisson_j) {
  return 1.0 / ((1 - poisson_i * poisson_i) / youngs_i_Pa + (1 - poisson_j * poisson_j) / youngs_j_Pa);
}

inline double hookeNormalStiffness(double youngs_eff_Pa, double radius_eff_m, double mass_eff_kg,
                                   double characteristic_velocity_m_s) {
  const double v = characteristic_velocity_m_s;
  const double sqrt_r = std::sqrt(radius_eff_m);
  return 16.0 / 15.0 * sqrt_r * youngs_eff_Pa *
         std::pow(15.0 * mass_eff_kg * v * v / (16.0 * sqrt_r * youngs_eff_Pa), 0.2);
}

// Region of a triangle: vertices a, b, c; edges ab, ac, bc; the face.
enum class TriangleRegion { A, B, C, AB, AC, BC, Face };

struct TrianglePoint {
  TriangleRegion region;
  // Along the region's edge from its first to its second node (edges); the face's barycentric
  // v (towards b) and w (towards c) otherwise.
  double t = 0, v = 0, w = 0;
  Point3 weights;  // barycentric weights of the closest point for a, b, c
};

inline TrianglePoint closestOnTriangle(const Point3& p, const Point3& a, const Point3& b, const Point3& c) {
  const auto sub = [](const Point3& u, const Point3& q) { return Point3{u[0] - q[0], u[1] - q[1], u[2] - q[2]}; };
  const auto dot = [](const Point3& u, const Point3& q) { return u[0] * q[0] + u[1] * q[1] + u[2] * q[2]; };
  const auto edge = [](TriangleRegion r, double t) {
    TrianglePoint e{r, t, 0, 0, {0, 0, 0}};
    const int first = r == TriangleRegion::BC ? 1 : 0, second = r == TriangleRegion::AB ? 1 : 2;
    e.weights[first] = 1 - t;
    e.weights[second] = t;
    return e;
  };
  const Point3 ab = sub(b, a), ac = sub(c, a), ap = sub(p, a);
  const double d1 = dot(ab, ap), d2 = dot(ac, ap);
  if (d1 <= 0 && d2 <= 0) return {TriangleRegion::A, 0, 0, 0, {1, 0, 0}};
  const Point3 bp = sub(p, b);
  const double d3 = dot(ab, bp), d4 = dot(ac, bp);
  if (d3 >= 0 && d4 <= d3) return {TriangleRegion::B, 0, 0, 0, {0, 1, 0}};
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return edge(TriangleRegion::AB, d1 / (d1 - d3));
  const Point3 cp = sub(p, c);
  const double d5 = dot(ab, cp), d6 = dot(ac, cp);
  if (d6 >= 0 && d5 <= d6) return {TriangleRegion::C, 0, 0, 0, {0, 0, 1}};
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return edge(TriangleRegion::AC, d2 / (d2 - d6));
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return edge(TriangleRegion::BC, (d4 - d3) / ((d4 - d3) + (d5 - d6)));
  const double denom = 1.0 / (va + vb + vc);
  const double v = vb * denom, w = vc * denom;
  return {TriangleRegion::Face, 0, v, w, {1 - v - w, v, w}};
}

}  // namespace demfem::physics

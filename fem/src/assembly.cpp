// Consistent M and K of quadratic solid elements (Hex20 serendipity, Tet10), isotropic linear
// elasticity, assembled into Eigen sparse matrices.
#include "demfem/fem/model.hpp"

#include <Eigen/Dense>

#include <array>
#include <cmath>
#include <stdexcept>
#include <string>

namespace demfem::fem {
namespace {

using Matrix6 = Eigen::Matrix<double, 6, 6>;

// Natural coordinates of the C3D20 corners; mid-edge nodes are the means of their two corners.
constexpr int kHexCorner[8][3] = {{-1, -1, -1}, {1, -1, -1}, {1, 1, -1}, {-1, 1, -1},
                                  {-1, -1, 1},  {1, -1, 1},  {1, 1, 1},  {-1, 1, 1}};
constexpr int kHexEdges[12][2] = {{0, 1}, {1, 2}, {2, 3}, {3, 0}, {4, 5}, {5, 6},
                                  {6, 7}, {7, 4}, {0, 4}, {1, 5}, {2, 6}, {3, 7}};
// Corner pairs of the C3D10 mid-edge nodes 4..9.
constexpr int kTetEdges[6][2] = {{0, 1}, {1, 2}, {2, 0}, {0, 3}, {1, 3}, {2, 3}};

// Shape functions N (n) and their derivatives dN/dxi (n x 3) at natural point p.
void hex20Shape(const Eigen::Vector3d& p, Eigen::VectorXd& N, Eigen::MatrixXd& dN) {
  N.resize(20);
  dN.resize(20, 3);
  for (int a = 0; a < 8; ++a) {
    const double xi = kHexCorner[a][0], eta = kHexCorner[a][1], zeta = kHexCorner[a][2];
    const double gx = 1 + xi * p.x(), gy = 1 + eta * p.y(), gz = 1 + zeta * p.z();
    const double s = xi * p.x() + eta * p.y() + zeta * p.z() - 2;
    N(a) = gx * gy * gz * s / 8;
    dN(a, 0) = xi * gy * gz * (s + gx) / 8;
    dN(a, 1) = eta * gx * gz * (s + gy) / 8;
    dN(a, 2) = zeta * gx * gy * (s + gz) / 8;
  }
  for (int e = 0; e < 12; ++e) {
    const int a = 8 + e;
    double c[3];
    for (int d = 0; d < 3; ++d) c[d] = 0.5 * (kHexCorner[kHexEdges[e][0]][d] + kHexCorner[kHexEdges[e][1]][d]);
    // One coordinate is 0 along the edge: N = (1 - q^2) prod over the others (1 + c r) / 4.
    double f[3], df[3];
    for (int d = 0; d < 3; ++d) {
      if (c[d] == 0) {
        f[d] = 1 - p(d) * p(d);
        df[d] = -2 * p(d);
      } else {
        f[d] = 1 + c[d] * p(d);
        df[d] = c[d];
      }
    }
    N(a) = f[0] * f[1] * f[2] / 4;
    dN(a, 0) = df[0] * f[1] * f[2] / 4;
    dN(a, 1) = f[0] * df[1] * f[2] / 4;
    dN(a, 2) = f[0] * f[1] * df[2] / 4;
  }
}

void tet10Shape(const Eigen::Vector3d& p, Eigen::VectorXd& N, Eigen::MatrixXd& dN) {
  N.resize(10);
  dN.resize(10, 3);
  const double L[4] = {1 - p.x() - p.y() - p.z(), p.x(), p.y(), p.z()};
  const double dL[4][3] = {{-1, -1, -1}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (int a = 0; a < 4; ++a) {
    N(a) = L[a] * (2 * L[a] - 1);
    for (int d = 0; d < 3; ++d) dN(a, d) = (4 * L[a] - 1) * dL[a][d];
  }
  for (int e = 0; e < 6; ++e) {
    const int i = kTetEdges[e][0], j = kTetEdges[e][1];
    N(4 + e) = 4 * L[i] * L[j];
    for (int d = 0; d < 3; ++d) dN(4 + e, d) = 4 * (dL[i][d] * L[j] + L[i] * dL[j][d]);
  }
}

struct QuadraturePoint {
  Eigen::Vector3d p;
  double w;
};

// Gauss-Legendre on [-1, 1].
std::vector<std::pair<double, double>> gauss1d(int n) {
  switch (n) {
    case 2: {
      const double a = 1 / std::sqrt(3.0);
      return {{-a, 1}, {a, 1}};
    }
    case 3: {
      const double a = std::sqrt(0.6);
      return {{-a, 5.0 / 9}, {0, 8.0 / 9}, {a, 5.0 / 9}};
    }
    case 4: {
      const double a = std::sqrt(3.0 / 7 - 2.0 / 7 * std::sqrt(1.2)), b = std::sqrt(3.0 / 7 + 2.0 / 7 * std::sqrt(1.2));
      const double wa = (18 + std::sqrt(30.0)) / 36, wb = (18 - std::sqrt(30.0)) / 36;
      return {{-b, wb}, {-a, wa}, {a, wa}, {b, wb}};
    }
    default:
      throw std::logic_error("gauss1d: unsupported order");
  }
}

std::vector<QuadraturePoint> hexRule(int n) {
  const auto g = gauss1d(n);
  std::vector<QuadraturePoint> rule;
  for (const auto& [x, wx] : g)
    for (const auto& [y, wy] : g)
      for (const auto& [z, wz] : g) rule.push_back({{x, y, z}, wx * wy * wz});
  return rule;
}

// Collapsed (conical product) Gauss rule on the unit tetrahedron: 4^3 points, exact for total
// degree 5 (the Jacobian of the collapse adds degree 2).
std::vector<QuadraturePoint> tetRule() {
  const auto g = gauss1d(4);
  std::vector<QuadraturePoint> rule;
  for (const auto& [a, wa] : g)
    for (const auto& [b, wb] : g)
      for (const auto& [c, wc] : g) {
        const double u = (a + 1) / 2, v = (b + 1) / 2, w = (c + 1) / 2;
        const double jac = (1 - u) * (1 - u) * (1 - v) / 8;  // includes the three [-1,1]->[0,1] maps
        rule.push_back({{u, v * (1 - u), w * (1 - u) * (1 - v)}, wa * wb * wc * jac});
      }
  return rule;
}

Matrix6 elasticity(const Material& m) {
  const double E = m.youngs_Pa, nu = m.poisson;
  const double lambda = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
  Matrix6 D = Matrix6::Zero();
  D.topLeftCorner<3, 3>().setConstant(lambda);
  for (int i = 0; i < 3; ++i) D(i, i) = lambda + 2 * mu;
  for (int i = 3; i < 6; ++i) D(i, i) = mu;
  return D;
}

}  // namespace

Assembled assemble(const Mesh& mesh, const Material& material, HexIntegration integration) {
  if (!(material.youngs_Pa > 0) || !(material.poisson > -1 && material.poisson < 0.5) || !(material.density_kg_m3 > 0))
    throw std::invalid_argument("FEM material needs E > 0 Pa, -1 < nu < 0.5 and rho > 0 kg/m^3 (got E = " +
                                std::to_string(material.youngs_Pa) + " Pa, nu = " + std::to_string(material.poisson) +
                                ", rho = " + std::to_string(material.density_kg_m3) + " kg/m^3)");
  const Matrix6 D = elasticity(material);
  const auto hex_stiffness_rule = hexRule(integration == HexIntegration::Reduced ? 2 : 3);
  const auto hex_mass_rule = hexRule(3);
  const auto tet_rule = tetRule();
  std::vector<Eigen::Triplet<double>> k_entries, m_entries;
  Eigen::VectorXd N;
  Eigen::MatrixXd dN;
  for (std::size_t e = 0; e < mesh.elements.size(); ++e) {
    const Element& el = mesh.elements[e];
    const int n = nodesPerElement(el.type);
    if (static_cast<int>(el.nodes.size()) != n)
      throw std::invalid_argument("element " + std::to_string(e) + " has " + std::to_string(el.nodes.size()) +
                                  " nodes, expected " + std::to_string(n));
    Eigen::MatrixXd X(n, 3);
    for (int a = 0; a < n; ++a) X.row(a) = mesh.nodes.at(static_cast<std::size_t>(el.nodes[a])).transpose();
    Eigen::MatrixXd Ke = Eigen::MatrixXd::Zero(3 * n, 3 * n), Me = Eigen::MatrixXd::Zero(n, n);
    auto integrate = [&](const std::vector<QuadraturePoint>& rule, bool stiffness) {
      for (const auto& q : rule) {
        if (el.type == ElementType::Hex20) hex20Shape(q.p, N, dN); else tet10Shape(q.p, N, dN);
        const Eigen::Matrix3d J = X.transpose() * dN;  // J(i, d) = dx_i / dxi_d
        const double det = J.determinant();
        if (!(det > 0))
          throw std::invalid_argument("element " + std::to_string(e) + " has a non-positive Jacobian (" +
                                      std::to_string(det) + ") at a quadrature point: inverted or badly ordered nodes");
        const double dV = det * q.w;
        if (!stiffness) {
          Me.noalias() += material.density_kg_m3 * dV * N * N.transpose();
          continue;
        }
        const Eigen::MatrixXd G = dN * J.inverse();  // dN/dx, n x 3
        Eigen::MatrixXd B = Eigen::MatrixXd::Zero(6, 3 * n);
        for (int a = 0; a < n; ++a) {
          const double gx = G(a, 0), gy = G(a, 1), gz = G(a, 2);
          B(0, 3 * a) = gx;
          B(1, 3 * a + 1) = gy;
          B(2, 3 * a + 2) = gz;
          B(3, 3 * a) = gy, B(3, 3 * a + 1) = gx;      // gamma_xy
          B(4, 3 * a + 1) = gz, B(4, 3 * a + 2) = gy;  // gamma_yz
          B(5, 3 * a) = gz, B(5, 3 * a + 2) = gx;      // gamma_xz
        }
        Ke.noalias() += dV * B.transpose() * D * B;
      }
    };
    integrate(el.type == ElementType::Hex20 ? hex_stiffness_rule : tet_rule, true);
    integrate(el.type == ElementType::Hex20 ? hex_mass_rule : tet_rule, false);
    for (int a = 0; a < n; ++a)
      for (int b = 0; b < n; ++b) {
        for (int i = 0; i < 3; ++i) {
          m_entries.emplace_back(3 * el.nodes[a] + i, 3 * el.nodes[b] + i, Me(a, b));
          for (int j = 0; j < 3; ++j) k_entries.emplace_back(3 * el.nodes[a] + i, 3 * el.nodes[b] + j, Ke(3 * a + i, 3 * b + j));
        }
      }
  }
  const auto dofs = static_cast<Eigen::Index>(3 * mesh.nodes.size());
  Assembled out;
  out.K.resize(dofs, dofs);
  out.M.resize(dofs, dofs);
  out.K.setFromTriplets(k_entries.begin(), k_entries.end());
  out.M.setFromTriplets(m_entries.begin(), m_entries.end());
  return out;
}

}  // namespace demfem::fem

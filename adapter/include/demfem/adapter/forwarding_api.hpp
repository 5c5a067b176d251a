// A coupling API that forwards every call to another one, unchanged (coupling_api.hpp states the
// calls' contract; this adds nothing to it): the base of the wrappers that watch a coupled run from
// between the FEM client and its DEM (test recorders, benchmark taps), each overriding only the
// calls it looks at and forwarding through inner(). advance() is not forwarded as one call: the
// API's default composes this wrapper's own calls, so a wrapper sees every position, simulate and
// force of a cycle. Header-only, standard library only (part of
// demfem::coupling_api).
//
// Pre: `inner` outlives the wrapper.
#pragma once

#include "demfem/adapter/coupling_api.hpp"

#include <filesystem>
#include <string>
#include <vector>

namespace demfem::adapter {

class ForwardingApi : public CouplingApi {
 public:
  explicit ForwardingApi(CouplingApi& inner) : inner_(inner) {}

  BackendInfo info() override { return inner_.info(); }
  std::vector<GeometryInfo> geometries() override { return inner_.geometries(); }
  double time() override { return inner_.time(); }
  NodeArray nodePositions(const std::string& geometry) override { return inner_.nodePositions(geometry); }
  NodeArray nodeForces(const std::string& geometry, ForceMode mode) override { return inner_.nodeForces(geometry, mode); }
  void setNodePositions(const std::string& geometry, const NodeArray& xyz) override { inner_.setNodePositions(geometry, xyz); }
  void simulate(double duration_s) override { inner_.simulate(duration_s); }
  RigidMotion rigidMotion(const std::string& geometry) override { return inner_.rigidMotion(geometry); }
  void setRigidMotion(const std::string& geometry, const RigidMotion& motion) override { inner_.setRigidMotion(geometry, motion); }
  void checkpoint(const std::filesystem::path& file) override { inner_.checkpoint(file); }
  void restore(const std::filesystem::path& file) override { inner_.restore(file); }
  void shutdown() override { inner_.shutdown(); }

 protected:
  CouplingApi& inner() { return inner_; }

 private:
  CouplingApi& inner_;
};

}  // namespace demfem::adapter

// demfem coupling API: what a DEM code offers the FEM client (paper Section 2.4, Fig. 3;
// docs/architecture.md section 2). One object per DEM simulation. Implemented by the built-in DEM, the
// LIGGGHTS backend, the remote proxy (this API over the ZeroMQ protocol) and analytic test backends.
//
// Contract
// - Units: SI (m, s, N). Arrays are row-major n x 3 (x, y, z of node 0, then node 1, ...).
// - Frame: node positions and forces are given in the geometry's LOCAL frame (docs/architecture.md section 10:
//   tool x across the width, y along the length with the tip at y = 0, z the travel direction).
//   The geometry's rigid motion (RigidMotion) maps local to bin coordinates; deformation is what
//   setNodePositions() adds on top of the undeformed keypoint positions.
// - Node ids: a geometry's keypoints are unique nodes 0..n-1 in the order of geometries()'s list;
//   the same ids index triangles, positions and forces. Backends that store per-triangle copies
//   (LIGGGHTS) merge them.
// - Force convention: nodeForces() is the force the particles exert ON the geometry's nodes.
//   A particle-triangle contact force is split to the triangle's three nodes by the barycentric
//   weights of the contact point (conserves force and moment). With ForceAveraging::IntervalMean
//   (default) it is the impulse over the last simulate() interval divided by its duration; with
//   Instantaneous, the value at the last DEM step (the paper's EDEM behaviour).
// - Pre/post: simulate(d) requires d >= 0 and advances time() by d (up to the DEM step: the backend
//   runs demStepCount(d, dt_DEM) = round(d / dt_DEM) steps and reports the time it reached; a
//   duration whose step count, or whose end time in steps, exceeds kMaxDemSteps is refused with
//   BadRequest and changes nothing). simulate(0) is allowed and changes
//   nothing but lets a client refresh derived data. setNodePositions() takes effect before the next
//   DEM step, with normals and neighbour data updated and contact history kept.
// - After construction: time() == 0 and every tool of the study rests, undeformed, at the start pose
//   of its motion plan (study/tool_motion.hpp): rigidMotion(tool) == {planToolMotion(study, tool)
//   .start_m, velocity 0, t0 0}. A backend never moves a tool by itself: the tool moves only by the
//   RigidMotion and node positions its client sets (rigidMotionOf() turns a plan phase into the
//   former). The analytic test backends, built from tools without soil, rest them at the bin origin.
// - Errors: every call throws CouplingError (with a code) on bad arguments (unknown geometry, wrong
//   array size, NaN) or a failed simulation; the object stays usable for shutdown()/checkpoint.
// - Header-only, standard library only (CMake package target demfem::coupling_api): a DEM code
//   outside demfem implements this interface and serves it with demfem::remote (server.hpp).
#pragma once

#include <array>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

namespace demfem::adapter {

enum class ErrorCode : std::int32_t {
  BadRequest = 1,       // malformed message or arguments
  UnknownGeometry = 2,
  SizeMismatch = 3,
  VersionMismatch = 4,
  SimulationFailed = 5, // blow-up, particle lost, backend error
  Timeout = 6,          // peer did not answer in time
  PeerGone = 7,
  Unsupported = 8,      // the backend does not offer this call (e.g. checkpoint)
  Internal = 9,
  Busy = 10,            // the server serves another client's session
};

class CouplingError : public std::runtime_error {
 public:
  CouplingError(ErrorCode code, const std::string& message)
      : std::runtime_error(message), code_(code) {}
  ErrorCode code() const { return code_; }

 private:
  ErrorCode code_;
};

enum class ForceMode { IntervalMean, Instantaneous };

struct BackendInfo {
  std::string backend;        // "builtin", "liggghts", "harmonic", ...
  std::string version;        // backend's own version string
  std::int32_t protocol_version = 1;
  double dem_time_step_s = 0; // the DEM step in use
  // The settled soil the simulation started from, as the JSON object text of
  // adapter::soilRecordJson() (settled_soil.hpp); empty for backends without soil.
  std::string soil_json;
};

struct GeometryInfo {
  std::string name;
  std::int32_t node_count = 0;
  std::vector<std::array<std::int32_t, 3>> triangles;  // node ids, outward normal by right-hand rule
};

// Rigid motion of a geometry in the bin frame: x_bin = origin + R * x_local + velocity * (t - t0).
// Tools are translated, never rotated, in the paper's studies; rotation is the identity unless set.
struct RigidMotion {
  std::array<double, 3> origin_m{0, 0, 0};         // bin position of the local origin at time t0_s
  std::array<double, 3> velocity_m_s{0, 0, 0};
  double t0_s = 0;
};

using NodeArray = std::vector<double>;  // n x 3, row-major

// Largest DEM step count a backend reaches (2^53: step counts and step * dt stay exact doubles).
inline constexpr std::int64_t kMaxDemSteps = std::int64_t{1} << 53;

// round(duration_s / dt_s), the steps simulate(duration_s) runs after `steps_done` steps. Throws
// CouplingError(BadRequest) for a duration that is negative or not finite, or when steps_done plus
// the result would exceed kMaxDemSteps.
inline std::int64_t demStepCount(double duration_s, double dt_s, std::int64_t steps_done) {
  if (!(duration_s >= 0) || !std::isfinite(duration_s))
    throw CouplingError(ErrorCode::BadRequest, "simulate(" + std::to_string(duration_s) +
                                                   "): the duration must be finite and >= 0");
  const double steps = std::round(duration_s / dt_s);
  // Compared as doubles before any conversion: 1e20 s must not reach llround.
  if (!(steps <= static_cast<double>(kMaxDemSteps - steps_done)))
    throw CouplingError(ErrorCode::BadRequest, "simulate(" + std::to_string(duration_s) + " s) would take the DEM past " +
                                                   std::to_string(kMaxDemSteps) + " steps of " + std::to_string(dt_s) +
                                                   " s; nothing simulated");
  return static_cast<std::int64_t>(steps);
}

class CouplingApi {
 public:
  virtual ~CouplingApi() = default;

  // Identity, version and DEM step. Cheap.
  virtual BackendInfo info() = 0;
  // The deformable geometries this simulation offers, with keypoint counts and triangles.
  virtual std::vector<GeometryInfo> geometries() = 0;
  // Current simulated time (s).
  virtual double time() = 0;

  // --- the four calls of the paper (EDEM Coupling Interface equivalents) ---
  // Current keypoint coordinates in the geometry's local frame (undeformed + deformation).
  virtual NodeArray nodePositions(const std::string& geometry) = 0;
  // Force of the particles on each keypoint (N), local frame, per `mode` (see contract above).
  virtual NodeArray nodeForces(const std::string& geometry, ForceMode mode = ForceMode::IntervalMean) = 0;
  // Moves the keypoints to `xyz` (local frame, n x 3). Takes effect before the next DEM step.
  virtual void setNodePositions(const std::string& geometry, const NodeArray& xyz) = 0;
  // Advances the DEM by `duration_s` (many DEM steps).
  virtual void simulate(double duration_s) = 0;
  // One coupling cycle's exchange (Fig. 3): setNodePositions(geometry, xyz) unless `xyz` is empty
  // (a rigid tool), simulate(duration_s), and nodeForces(geometry, mode) of that interval returned;
  // the client's `work` (its outputs of the step; it must not call this object) is done meanwhile
  // where the DEM runs elsewhere. The remote proxy makes it one round trip: it sends the request,
  // runs `work`, then waits for the reply. Same pre/post and errors as the three calls. An
  // exception from `work` propagates and the backend stays usable; whether the interval was then
  // simulated is not specified. A backend need not override it.
  virtual NodeArray advance(const std::string& geometry, const NodeArray& xyz, double duration_s, ForceMode mode,
                            const std::function<void()>& work) {
    if (work) work();
    if (!xyz.empty()) setNodePositions(geometry, xyz);
    simulate(duration_s);
    return nodeForces(geometry, mode);
  }

  // --- what a real client needs besides ---
  virtual RigidMotion rigidMotion(const std::string& geometry) = 0;
  virtual void setRigidMotion(const std::string& geometry, const RigidMotion& motion) = 0;
  // Writes everything needed to resume bit-identically; restore() reads it back.
  virtual void checkpoint(const std::filesystem::path& file) = 0;
  virtual void restore(const std::filesystem::path& file) = 0;
  // Releases resources; further calls throw. Idempotent.
  virtual void shutdown() = 0;
};

}  // namespace demfem::adapter

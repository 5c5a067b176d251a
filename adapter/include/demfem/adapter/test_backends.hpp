// Analytic test backends ("solver dummies", as in preCICE): implementations of the coupling API
// whose node forces are known closed-form functions of time and node position, so that coupled
// runs can be checked against the FEM alone and against closed-form answers.
//
// Loaded nodes: the keypoints of the tip rows, i.e. with undeformed local y <= tip_band_m (default:
// half a keypoint spacing, so exactly the tip row y = 0 on both faces; n_tip nodes). Every other
// node gets zero force. All forces act along the tool's local z (travel direction). X_i is the
// undeformed position, x_i the position last set by setNodePositions(), W the tool width.
//
//   constant:  f_i(t) = F / n_tip
//   harmonic:  f_i(t) = F / n_tip * (1 + X_i,x / W) * sin(2 pi f t)      (sum over the row: F sin)
//   spring:    f_i    = -k / n_tip * (x_i,z - X_i,z)                      (tip row tied to ground)
//
// Force convention (coupling_api.hpp): nodeForces(IntervalMean) is the exact time average over the
// last simulate() interval [t0, t1], integrated analytically: for the harmonic load
// F/n_tip (1 + X_x/W) sin(w (t0+t1)/2) sinc(w (t1-t0)/2); the constant and spring loads are constant
// over an interval (positions change only between intervals). Before the first simulate(), or after
// simulate(0), the interval is empty and the instantaneous value at time() is returned.
// Time is step_count * dem_time_step_s exactly (simulate(d) runs demStepCount(d, dt) steps; the
// count never passes kMaxDemSteps, so time cannot wrap).
// checkpoint()/restore() write/read a checkpoint_file.hpp container (kind "test-KIND"); a restored
// backend continues bit-identically, and a refused file leaves the backend as it was.
// Built from tools without soil, every tool rests at the bin origin (velocity 0, t0 0) until the
// client sets a RigidMotion; the loads above do not depend on it.
#pragma once

#include "demfem/adapter/coupling_api.hpp"
#include "demfem/study/backend_capabilities.hpp"
#include "demfem/study/study.hpp"

#include <memory>
#include <string>
#include <vector>

namespace demfem::adapter {

struct TestLoad {
  double force_N = -10.0;        // F: total on the tip row, along local z (negative: against travel)
  double frequency_Hz = 20.0;    // f, harmonic only
  double stiffness_N_m = 1.0e4;  // k, spring only: total over the tip row
  double tip_band_m = -1.0;      // < 0: half the keypoint spacing
  double dem_time_step_s = 1.0e-5;
};

// Names accepted by makeTestBackend().
const std::vector<std::string>& testBackendNames();

// One geometry per tool (plate tools only: the keypoint surface of plate_surface.hpp). Throws
// CouplingError(Unsupported) for an unknown `kind` or a non-plate tool, (BadRequest) for a
// non-positive time step.
// What each test backend offers: no soil (no contact laws), plate tools, checkpoints.
inline study::BackendCapabilities testBackendCapabilities(const std::string& name) {
  return {name, false, {}, {}, {}, {study::GeometryKind::Plate}, true};
}

std::unique_ptr<CouplingApi> makeTestBackend(const std::string& kind, const std::vector<study::Tool>& tools,
                                             const TestLoad& load);

}  // namespace demfem::adapter

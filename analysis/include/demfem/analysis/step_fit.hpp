// demfem analysis: a damped step response fitted to a whole calibration-weight record (paper
// Section 2.10.1 / 3.1, Figs. 5c, 7 and 8; docs/analysis.md "Calibration-weight runs").
//
// Model (one underdamped mode excited by a weight hung at t0, at rest before it):
//   y(t) = y0                                                       for t < t0,
//   y(t) = y_ss + (y0 - y_ss) exp(-zeta w_n tau) (cos w_d tau + zeta / sqrt(1 - zeta^2) sin w_d tau)
//                                                                   for tau = t - t0 >= 0,
//   w_d = 2 pi f_d (the damped frequency, what a cycle counter measures), w_n = w_d / sqrt(1 - zeta^2).
// The curve and its slope are continuous at t0, so t0 is fitted like the other four parameters
// (y0, y_ss, t0, f_d, zeta) by nonlinear least squares over every sample (Levenberg-Marquardt),
// with 0 < zeta < 1 and f_d > 0 enforced by the parametrisation. Initial values: y0 from the first
// samples, y_ss from the last fifth, the first overshoot's height and time for zeta and f_d.
// A record that has not settled (the tail still rings) is fitted as well as a settled one: the
// steady value is the model's asymptote, not a tail mean.
//
// Noise: residual_rms = sqrt(sum r^2 / (n - 5)), r = y - model; the standard errors are
// residual_rms * sqrt(diag((J^T J)^-1)) at the optimum (J: Jacobian of the model in the five
// parameters), i.e. valid for white noise.
//
// Pre: time strictly increasing, equally long columns, at least 20 samples, values finite.
// Throws InputError naming `what` (e.g. "run.csv: column 'force_N'") when there are too few samples,
// the signal does not step (no change above its noise), it never overshoots (no oscillation to fit)
// or the fit does not converge.
//
// Units: time s, values in the signal's unit (N or mm), frequencies Hz, damping ratio 1.
#pragma once

#include "demfem/analysis/recording.hpp"  // InputError

#include <cstddef>
#include <string>
#include <vector>

namespace demfem::analysis {

struct StepResponseFit {
  double initial = 0.0;        // y0: value before the step (signal unit)
  double steady = 0.0;         // y_ss: the asymptote (signal unit)
  double step_time_s = 0.0;    // t0: when the weight was hung
  double frequency_Hz = 0.0;   // f_d: damped frequency
  double damping_ratio = 0.0;  // zeta
  double natural_frequency_Hz = 0.0;  // f_n = f_d / sqrt(1 - zeta^2)
  double residual_rms = 0.0;   // noise of the record about the fitted curve (signal unit)
  // One-sigma standard errors of the fitted values (same units).
  double steady_error = 0.0;
  double frequency_error_Hz = 0.0;
  double damping_ratio_error = 0.0;
  std::size_t samples = 0;
  int iterations = 0;

  // The fitted curve at time t (s).
  double at(double t_s) const;
};

// Fits the model of the header comment to (time_s, value). See there for pre- and postconditions.
StepResponseFit fitStepResponse(const std::vector<double>& time_s, const std::vector<double>& value,
                                const std::string& what = "signal");

}  // namespace demfem::analysis

// Test fixture shared by the weight-drop generators of the diagnosis tests (beam_weight_drop.hpp,
// calculix_weight_drop.hpp; docs/diagnosis.md): the DAQ (sample rate, factors, noise, mains hum),
// the exact step response of one damped mode, and the raw recording of a weight drop: t, force,
// deformation in DAQ units, quantised to whole units, Gaussian noise and an optional mains hum, a
// resting baseline before the weight is hung. Nothing of the project's FEM or diagnosis; the raw
// recording writer of analysis/ is the data format.
#pragma once

#include "demfem/analysis/synthetic.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numbers>
#include <random>
#include <vector>

namespace demfem::campaign::test {

inline constexpr double kStandardGravity_m_s2 = 9.80665;

struct Daq {
  double sample_rate_Hz = 1000, duration_s = 3.0, drop_time_s = 0.2;
  double force_factor_N_per_unit = 0.002, deformation_factor_mm_per_unit = 0.0002;
  double force_noise_N = 0.002, deformation_noise_mm = 0.0002;
  double force_hum_N = 0.0, deformation_hum_mm = 0.0, hum_Hz = 50;  // mains hum amplitude, random phase
  std::uint64_t seed = 1;

  // Sample times of a recording, and the time since the weight was hung at each (0 before).
  std::vector<double> times_s() const {
    std::vector<double> t;
    const auto samples = static_cast<long>(std::lround(duration_s * sample_rate_Hz));
    for (long i = 0; i < samples; ++i) t.push_back(static_cast<double>(i) / sample_rate_Hz);
    return t;
  }
  std::vector<double> timesAfterDrop_s() const {
    std::vector<double> after;
    for (double t : times_s()) after.push_back(std::max(0.0, t - drop_time_s));
    return after;
  }
};

// A weight drop's true channels (gains and offsets applied), no noise.
struct ChannelResponse {
  std::vector<double> t_s, force_N, deformation_mm;
};

// One mode's coordinate, velocity and acceleration at time t after a step of modal force f at t = 0
// from rest: q'' + 2 zeta w q' + w^2 q = f (w^2 = omega2), underdamped or overdamped (the high modes
// under stiffness-proportional damping).
struct ModalState {
  double q = 0, qd = 0, qdd = 0;
};

inline ModalState modalStep(double omega2, double zeta, double f, double t) {
  const double w = std::sqrt(omega2), s = f / omega2;
  if (zeta >= 1) {
    const double root = std::sqrt(zeta * zeta - 1), r1 = -w * (zeta - root), r2 = -w * (zeta + root);
    const double e1 = std::exp(r1 * t), e2 = std::exp(r2 * t);
    return {s * (1 - (r2 * e1 - r1 * e2) / (r2 - r1)), -s * r1 * r2 * (e1 - e2) / (r2 - r1), -s * r1 * r2 * (r1 * e1 - r2 * e2) / (r2 - r1)};
  }
  const double wd = w * std::sqrt(1 - zeta * zeta), decay = std::exp(-zeta * w * t);
  const double c = std::cos(wd * t), sn = std::sin(wd * t), ratio = zeta / std::sqrt(1 - zeta * zeta);
  return {s * (1 - decay * (c + ratio * sn)), s * decay * (w / std::sqrt(1 - zeta * zeta)) * sn,
          s * omega2 * decay * (c - ratio * sn)};  // q'' from q'' = -2 zeta w q' - w^2 (q - s)
}

// The raw recording of one weight from its channels (`r` at daq.timesAfterDrop_s()): resting
// baseline, then the response; noise, hum and quantisation.
inline analysis::SyntheticRecording daqRecording(const ChannelResponse& r, double mass_kg, const Daq& daq, int repeat = 1) {
  const std::vector<double> t = daq.times_s();
  const std::uint64_t stream = daq.seed + static_cast<std::uint64_t>(repeat) * 7919;
  std::mt19937_64 rng(stream), hum_rng(~stream);  // the hum's phases apart: the noise is as without hum
  std::normal_distribution<double> noise(0.0, 1.0);
  std::uniform_real_distribution<double> phase(0.0, 2 * std::numbers::pi);
  const double force_phase = phase(hum_rng), deformation_phase = phase(hum_rng);
  analysis::SyntheticRecording rec;
  rec.header = {"t", "force", "deformation"};
  rec.columns.assign(3, {});
  for (std::size_t i = 0; i < t.size(); ++i) {
    const bool loaded = t[i] >= daq.drop_time_s;
    const double hum = 2 * std::numbers::pi * daq.hum_Hz * t[i];
    const double force = (loaded ? r.force_N[i] : 0.0) + daq.force_noise_N * noise(rng) + daq.force_hum_N * std::sin(hum + force_phase);
    const double deformation = (loaded ? r.deformation_mm[i] : 0.0) + daq.deformation_noise_mm * noise(rng) +
                               daq.deformation_hum_mm * std::sin(hum + deformation_phase);
    rec.columns[0].push_back(t[i]);
    rec.columns[1].push_back(std::round(force / daq.force_factor_N_per_unit));
    rec.columns[2].push_back(std::round(deformation / daq.deformation_factor_mm_per_unit));
  }
  rec.sidecar = {{"tool", "tool"},
                 {"mass_kg", mass_kg},
                 {"sample_rate_hz", daq.sample_rate_Hz},
                 {"force_factor", daq.force_factor_N_per_unit},
                 {"deformation_factor", daq.deformation_factor_mm_per_unit},
                 {"repeat", repeat}};
  return rec;
}

}  // namespace demfem::campaign::test

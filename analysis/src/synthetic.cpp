#include "demfem/analysis/synthetic.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <numbers>
#include <random>
#include <stdexcept>

namespace demfem::analysis {
namespace {

constexpr double kTwoPi = 2.0 * std::numbers::pi;

struct Fluctuation {
  std::vector<double> frequency_Hz, amplitude, phase;
  double at(double t) const {
    double sum = 0.0;
    for (std::size_t j = 0; j < frequency_Hz.size(); ++j) sum += amplitude[j] * std::sin(kTwoPi * frequency_Hz[j] * t + phase[j]);
    return sum;
  }
};

Fluctuation makeFluctuation(const SoilBinTruth& truth, std::mt19937_64& rng) {
  Fluctuation fl;
  std::uniform_real_distribution<double> phase(0.0, kTwoPi);
  if (truth.fluctuation_a <= 0.0) return fl;
  for (double f = truth.fluctuation_low_Hz; f <= truth.fluctuation_high_Hz + 1e-12; f += truth.fluctuation_spacing_Hz) {
    fl.frequency_Hz.push_back(f);
    fl.amplitude.push_back(truth.fluctuation_a * std::pow(f, truth.fluctuation_b));
    fl.phase.push_back(phase(rng));
  }
  return fl;
}

}  // namespace

SyntheticRecording makeSoilBinRecording(const SoilBinTruth& truth, RecordingFormat format) {
  std::mt19937_64 rng(truth.seed);
  const Fluctuation fluctuation = makeFluctuation(truth, rng);  // shared: the elastic tool's deformation follows the force
  std::normal_distribution<double> noise(0.0, truth.noise_fraction);
  const double duration = truth.endTime() + truth.rest_after_s;
  const auto samples = static_cast<std::size_t>(std::floor(duration * truth.sample_rate_Hz)) + 1;
  const bool raw = format == RecordingFormat::Raw;

  std::vector<double> t, x, force, deformation, tilt;
  for (std::size_t i = 0; i < samples; ++i) {
    const double time = static_cast<double>(i) / truth.sample_rate_Hz;
    const double moved = std::clamp(truth.velocity_mm_s * (time - truth.start_time_s), 0.0, truth.stroke_mm);
    double load = 0.0;
    if (time > truth.endTime()) load = truth.relaxed_fraction;
    else if (moved < truth.ramp_mm) load = moved / truth.ramp_mm;
    else if (moved < truth.wall_start_mm) load = 1.0;
    else load = 1.0 + truth.wall_gain * std::pow((moved - truth.wall_start_mm) / (truth.stroke_mm - truth.wall_start_mm), 2.0);
    const bool moving = time > truth.start_time_s && time <= truth.endTime();
    const double fluct = moving ? std::min(load, 1.0) * fluctuation.at(time) : 0.0;
    const double f = truth.force_N * (load + fluct + noise(rng));
    const double d = truth.deformation_mm * (load + fluct + noise(rng));
    t.push_back(time);
    x.push_back(moved);
    if (raw) {
      force.push_back(f / truth.force_factor_N_per_unit + truth.force_offset_units);
      deformation.push_back(d / truth.deformation_factor_mm_per_unit + truth.deformation_offset_units);
    } else {
      force.push_back(f);
      deformation.push_back(d);
      tilt.push_back(truth.tilt_deg_per_mm * d);
    }
  }
  SyntheticRecording rec;
  if (raw) {
    rec.header = {"t", "force", "deformation"};
    rec.columns = {t, force, deformation};
    rec.sidecar = {{"tool", truth.tool},
                   {"depth_mm", truth.depth_mm},
                   {"stroke_mm", truth.stroke_mm},
                   {"sample_rate_hz", truth.sample_rate_Hz},
                   {"force_factor", truth.force_factor_N_per_unit},
                   {"deformation_factor", truth.deformation_factor_mm_per_unit},
                   {"repeat", truth.repeat}};
  } else {
    rec.header = {"t_s", "displacement_mm", "force_N", "deformation_mm", "tilt_deg"};
    rec.columns = {t, x, force, deformation, tilt};
    rec.sidecar = {{"tool", truth.tool}, {"depth_mm", truth.depth_mm}, {"repeat", truth.repeat}, {"complete", true}};
  }
  return rec;
}

SyntheticRecording makeWeightDropRecording(const WeightDropTruth& truth, RecordingFormat format) {
  std::mt19937_64 rng(truth.seed);
  std::normal_distribution<double> noise(0.0, truth.noise_fraction);
  const double zeta = truth.damping_ratio;
  const double wd = kTwoPi * truth.frequency_Hz;
  const double wn = wd / std::sqrt(1.0 - zeta * zeta);
  const auto samples = static_cast<std::size_t>(std::floor(truth.duration_s * truth.sample_rate_Hz)) + 1;
  const bool raw = format == RecordingFormat::Raw;
  std::vector<double> t, force, deformation;
  for (std::size_t i = 0; i < samples; ++i) {
    const double time = static_cast<double>(i) / truth.sample_rate_Hz;
    const double tau = time - truth.drop_time_s;
    const double shape =
        tau < 0.0 ? 0.0 : 1.0 - std::exp(-zeta * wn * tau) * (std::cos(wd * tau) + zeta / std::sqrt(1.0 - zeta * zeta) * std::sin(wd * tau));
    const double f = truth.force_N * (shape + noise(rng));
    const double d = truth.deformation_mm * (shape + noise(rng));
    t.push_back(time);
    force.push_back(raw ? f / truth.force_factor_N_per_unit : f);
    deformation.push_back(raw ? d / truth.deformation_factor_mm_per_unit : d);
  }
  SyntheticRecording rec;
  if (raw) {
    rec.header = {"t", "force", "deformation"};
    rec.sidecar = {{"tool", truth.tool},
                   {"mass_kg", truth.mass_kg},
                   {"sample_rate_hz", truth.sample_rate_Hz},
                   {"force_factor", truth.force_factor_N_per_unit},
                   {"deformation_factor", truth.deformation_factor_mm_per_unit},
                   {"repeat", truth.repeat}};
  } else {
    rec.header = {"t_s", "force_N", "deformation_mm"};
    rec.sidecar = {{"tool", truth.tool}, {"mass_kg", truth.mass_kg}, {"repeat", truth.repeat}, {"complete", true}};
  }
  rec.columns = {t, force, deformation};
  return rec;
}

void writeSyntheticRecording(const SyntheticRecording& recording, const std::filesystem::path& csv_path) {
  std::ofstream csv(csv_path);
  for (std::size_t c = 0; c < recording.header.size(); ++c) csv << (c ? "," : "") << recording.header[c];
  csv << '\n';
  char buffer[32];
  for (std::size_t i = 0; i < recording.columns.front().size(); ++i) {
    for (std::size_t c = 0; c < recording.columns.size(); ++c) {
      std::snprintf(buffer, sizeof buffer, "%.7g", recording.columns[c][i]);
      csv << (c ? "," : "") << buffer;
    }
    csv << '\n';
  }
  if (!csv) throw std::runtime_error("cannot write " + csv_path.string());
  std::ofstream sidecar(std::filesystem::path(csv_path).replace_extension(".json"));
  sidecar << recording.sidecar.dump(2) << '\n';
  if (!sidecar) throw std::runtime_error("cannot write the sidecar of " + csv_path.string());
}

}  // namespace demfem::analysis

// Test fixture: the hidden effects of the recovery matrix (docs/diagnosis.md, "Recovery matrix").
// Weight drops of the narrow PMMA tool (tests/campaign/data/narrow_weight_drop.json: 0.125 and 0.25
// kg, two repeats each) made by the independent CalculiX model of calculix_weight_drop.hpp (the
// study's plate tool, C3D20R, on its own mesh) with effects drawn at random: every cause of the
// diagnosis' catalogue, pairs of them, effects outside the catalogue, and none. Nothing here
// includes or assumes code of the diagnosis (campaign/, fem/); the raw recording writer of
// analysis/ is the data format.
//
// Each repeat is its own hanging of the weight: besides the DAQ noise (Gaussian, quantisation, a
// mains hum) it scatters from repeat to repeat as a laboratory's repeats do (RepeatScatter: the
// modulus with the room's temperature, the damping with the hook's friction, where the weight hangs
// on the pan). Without it the DAQ noise alone, on a 3 s record at 1 kHz ringing for ten cycles, puts
// the just-detectable change of E at 7e-7 and of the load-cell gain at 1e-5, far below any
// difference between two correct models of one tool: every draw would be a null case.
//
// Just detectable, in the generator's own terms: the quantities of a weight drop are, per weight and
// channel, the steady value, the damped frequency and the damping ratio of a one-mode step response
// y0 + A (1 - exp(-zeta w_n tau) (cos w_d tau + zeta / sqrt(1 - zeta^2) sin w_d tau)), tau = t - t0
// (with the nuisance parameters y0 and t0). Their standard errors (of the mean over the repeats):
// the Cramer-Rao bound of that model at the nominal tool's first mode under the DAQ noise,
// sigma^2 (J^T J)^-1, J the model's Jacobian at the samples, sigma^2 = noise^2 + quantum^2 / 12 +
// hum^2 / 2 per channel, plus the repeat scatter's variance (the squared first-order change of the
// quantity for one standard deviation of each scatter term), over the number of repeats.
// The change an effect makes in a quantity is the first-order (Gauss-Newton) change of the
// one-mode fit, (J^T J)^-1 J^T (y_effect - y_nominal), on the noiseless channels. An effect's
// amount is just detectable (1x) when the largest change over every quantity, channel and weight
// is 3 standard errors; found by bisection per effect and direction, cached per process.
//
// Draws (deterministic for a master seed and a draw index): in each block of five indices, two
// single catalogue effects (cycling through the catalogue in order), one pair of catalogue effects
// of different families, one effect outside the catalogue and one null case. A drawn effect's
// amount is log-uniform from 1x to 10x its detectable amount (a smaller upper end where the
// effect's physical range ends), its direction and channel at random.
#pragma once

#include "calculix_weight_drop.hpp"

#include <Eigen/Dense>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <map>
#include <mutex>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace demfem::campaign::test {

inline const std::vector<double>& recoveryMasses_kg() {
  static const std::vector<double> masses{0.125, 0.25};
  return masses;
}
inline constexpr int kRecoveryRepeats = 2;

// The recordings' DAQ: the hidden-effect tests' channels (docs/diagnosis.md) with a mains hum of half
// the Gaussian noise on each channel.
inline Daq recoveryDaq(std::uint64_t seed) {
  Daq daq;
  daq.force_hum_N = 0.5 * daq.force_noise_N;
  daq.deformation_hum_mm = 0.5 * daq.deformation_noise_mm;
  daq.seed = seed;
  return daq;
}

struct EffectKind {
  const char* id;
  bool in_catalogue;
  const char* family;       // pairs never join two effects of one family
  const char* amount_unit;  // of Effect::amount
  int variants;             // directions or channels
  const char* description;
};

// Catalogue ids as the diagnosis names them (docs/diagnosis.md), then the effects outside it.
inline const std::vector<EffectKind>& effectKinds() {
  static const std::vector<EffectKind> kinds{
      {"young_modulus", true, "modulus", "relative", 2, "E x (1 +- a)"},
      {"clamp_compliance", true, "clamp", "L/EI", 1, "root spring k_theta = EI / (L a), L the free length"},
      {"mass_damping", true, "damping", "1/s", 1, "beta_per_s (multiplies M) = a"},
      {"damping_form", true, "damping", "relative", 2,
       "alpha_s and beta_per_s together: the first mode's damping ratio x (1 + a) at the heavy weight and right at the light "
       "one, or x (1 - a) at the light weight and right at the heavy one"},
      {"added_mass", true, "mass", "kg", 1, "unmodelled tip mass a (inertia, tared weight)"},
      {"force_sensor_gain", true, "force", "relative", 2, "force channel x (1 +- a)"},
      {"deformation_sensor_gain", true, "deformation", "relative", 2, "deformation channel x (1 +- a)"},
      {"force_sensor_offset", true, "force", "N", 2, "force channel +- a once the weight hangs"},
      {"deformation_sensor_offset", true, "deformation", "mm", 2, "deformation channel +- a once the weight hangs"},
      {"channel_lowpass", false, "filter", "s", 2, "first-order low-pass of time constant a on the force (0) or deformation (1) channel"},
      {"load_dependent_modulus", false, "modulus", "relative", 2,
       "E x (1 +- a (m - m_mid) / (m_heavy - m_mid)): stiffer (or softer) with the load, right at the mean weight"},
  };
  return kinds;
}

inline int kindIndex(const std::string& id) {
  const auto& kinds = effectKinds();
  for (std::size_t i = 0; i < kinds.size(); ++i)
    if (id == kinds[i].id) return static_cast<int>(i);
  throw std::invalid_argument("unknown effect " + id);
}

inline std::vector<int> catalogueKinds() {
  std::vector<int> out;
  for (std::size_t i = 0; i < effectKinds().size(); ++i)
    if (effectKinds()[i].in_catalogue) out.push_back(static_cast<int>(i));
  return out;
}

inline std::vector<int> outsideKinds() {
  std::vector<int> out;
  for (std::size_t i = 0; i < effectKinds().size(); ++i)
    if (!effectKinds()[i].in_catalogue) out.push_back(static_cast<int>(i));
  return out;
}

struct Effect {
  int kind = 0, variant = 0;
  double amount = 0;      // in effectKinds()[kind].amount_unit
  double detectable = 0;  // the amount at 1x
  const EffectKind& info() const { return effectKinds()[static_cast<std::size_t>(kind)]; }
  double multiple() const { return amount / detectable; }
};

// Repeat-to-repeat scatter (standard deviations, independent per repeat): E x (1 + modulus N),
// alpha_s x (1 + damping N), the weight's centroid on the pan moved by load_position_m N.
struct RepeatScatter {
  double modulus = 0.003;         // 0.3 % per kelvin of PMMA's modulus, about one kelvin
  double damping = 0.05;
  double load_position_m = 0.0002;  // a hook in a notch of the pan
};

// The nominal tool: the study's (tests/campaign/data/narrow_weight_drop.json).
inline const CalculixTool& recoveryTool() {
  static const CalculixTool tool = calculixToolFromStudy(std::filesystem::path(DEMFEM_SOURCE_DIR) / "tests/campaign/data/narrow_weight_drop.json");
  return tool;
}

// The tool and the sensor chain the recordings are made from.
struct HiddenTruth {
  CalculixTool tool;
  double modulus_load_slope = 0;  // E x (1 + slope (m - m_mid) / (m_heavy - m_mid))
  double lowpass_tau_s = 0;
  int lowpass_channel = 0;        // 0 force, 1 deformation
};

// First-mode angular frequency of the nominal tool at each weight (lightest first).
inline std::vector<double> firstModeOmegas(const CalculixTool& nominal) {
  std::vector<double> w;
  for (double m : recoveryMasses_kg()) w.push_back(std::sqrt(calculixModes(nominal, m).omega2(0)));
  return w;
}

// The largest amount damping_form can take with alpha_s and beta_per_s both non-negative (variant 0:
// the heavy weight's ratio raised; 1: the light weight's lowered), for a nominal tool with beta = 0.
inline double dampingFormLimit(const CalculixTool& nominal, int variant) {
  const auto w = firstModeOmegas(nominal);
  const double ratio2 = std::pow(w[0] / w[1], 2);  // (light / heavy)^2 > 1
  return variant == 0 ? ratio2 - 1 : 1 - 1 / ratio2;
}

inline void applyEffect(const Effect& e, const CalculixTool& nominal, HiddenTruth& h) {
  const std::string id = e.info().id;
  const double sign = e.variant == 0 ? 1.0 : -1.0, a = e.amount;
  CalculixTool& b = h.tool;
  if (id == "young_modulus") {
    b.E_Pa *= 1 + sign * a;
  } else if (id == "clamp_compliance") {
    b.k_theta_Nm_per_rad = nominal.freeEIoverL() / a;
  } else if (id == "mass_damping") {
    b.beta_per_s += a;
  } else if (id == "damping_form") {
    // zeta(w) = alpha w / 2 + beta / (2 w) through the two weights' targets.
    const auto w = firstModeOmegas(nominal);
    const double zl = nominal.alpha_s * w[0] / 2 * (e.variant == 1 ? 1 - a : 1.0);
    const double zh = nominal.alpha_s * w[1] / 2 * (e.variant == 0 ? 1 + a : 1.0);
    Eigen::Matrix2d A;
    A << w[0] / 2, 1 / (2 * w[0]), w[1] / 2, 1 / (2 * w[1]);
    const Eigen::Vector2d ab = A.partialPivLu().solve(Eigen::Vector2d(zl, zh));
    b.alpha_s = ab(0), b.beta_per_s = ab(1);
  } else if (id == "added_mass") {
    b.tip_mass_kg += a;
  } else if (id == "force_sensor_gain") {
    b.force_gain *= 1 + sign * a;
  } else if (id == "deformation_sensor_gain") {
    b.deformation_gain *= 1 + sign * a;
  } else if (id == "force_sensor_offset") {
    b.force_offset_N += sign * a;
  } else if (id == "deformation_sensor_offset") {
    b.deformation_offset_mm += sign * a;
  } else if (id == "channel_lowpass") {
    h.lowpass_tau_s = a, h.lowpass_channel = e.variant;
  } else if (id == "load_dependent_modulus") {
    h.modulus_load_slope = sign * a;
  } else {
    throw std::invalid_argument("no model for effect " + id);
  }
}

inline HiddenTruth hiddenTruth(const std::vector<Effect>& effects) {
  const CalculixTool& nominal = recoveryTool();
  HiddenTruth h{nominal};
  for (const Effect& e : effects) applyEffect(e, nominal, h);
  return h;
}

// The noiseless channels of every weight (recoveryMasses_kg()), at daq.timesAfterDrop_s(), zero
// before the weight is hung.
inline std::vector<ChannelResponse> hiddenResponses(const HiddenTruth& h, const Daq& daq) {
  const auto& masses = recoveryMasses_kg();
  const double mid = 0.5 * (masses.front() + masses.back()), half = masses.back() - mid;
  const std::vector<double> t = daq.times_s();
  std::vector<ChannelResponse> out;
  for (double m : masses) {
    CalculixTool b = h.tool;
    b.E_Pa *= 1 + h.modulus_load_slope * (m - mid) / half;
    ChannelResponse r = calculixWeightDrop(b, m, daq.timesAfterDrop_s());
    for (std::size_t i = 0; i < t.size(); ++i)
      if (t[i] < daq.drop_time_s) r.force_N[i] = r.deformation_mm[i] = 0;
    if (h.lowpass_tau_s > 0) {
      auto& y = h.lowpass_channel == 0 ? r.force_N : r.deformation_mm;
      const double c = 1 - std::exp(-1 / (daq.sample_rate_Hz * h.lowpass_tau_s));
      for (std::size_t i = 1; i < y.size(); ++i) y[i] = y[i - 1] + c * (y[i] - y[i - 1]);
    }
    out.push_back(std::move(r));
  }
  return out;
}

// The one-mode quantities' first-order changes in standard errors (file comment).
class Detectability {
 public:
  explicit Detectability(const Daq& daq) : daq_(daq) {
    const CalculixTool& nominal = recoveryTool();
    const std::vector<double> t = daq.times_s();
    const double quantum_F = daq.force_factor_N_per_unit, quantum_d = daq.deformation_factor_mm_per_unit;
    const std::array<double, 2> sigma{
        std::sqrt(std::pow(daq.force_noise_N, 2) + quantum_F * quantum_F / 12 + std::pow(daq.force_hum_N, 2) / 2),
        std::sqrt(std::pow(daq.deformation_noise_mm, 2) + quantum_d * quantum_d / 12 + std::pow(daq.deformation_hum_mm, 2) / 2)};
    nominal_ = hiddenResponses(HiddenTruth{nominal}, daq);
    for (double m : recoveryMasses_kg()) {
      const double w = std::sqrt(calculixModes(nominal, m).omega2(0)), zeta = nominal.dampingRatio(w);
      const double f_d = w * std::sqrt(1 - zeta * zeta) / (2 * std::numbers::pi);
      const ChannelResponse steady = calculixWeightDrop(nominal, m, {1e3});
      for (int c = 0; c < 2; ++c) {
        const double A = c == 0 ? steady.force_N[0] : steady.deformation_mm[0];
        const Eigen::Matrix<double, 5, 1> theta(0.0, A, daq.drop_time_s, f_d, zeta);
        Eigen::MatrixXd J(static_cast<Eigen::Index>(t.size()), 5);
        for (int k = 0; k < 5; ++k) {
          const double h = k == 0 ? 1e-6 * std::abs(A) : k == 2 ? 1e-7 : 1e-6 * std::abs(theta(k));
          Eigen::Matrix<double, 5, 1> up = theta, down = theta;
          up(k) += h, down(k) -= h;
          for (std::size_t i = 0; i < t.size(); ++i)
            J(static_cast<Eigen::Index>(i), k) = (oneMode(up, t[i]) - oneMode(down, t[i])) / (2 * h);
        }
        const Eigen::MatrixXd JtJ_inv = (J.transpose() * J).inverse();
        Channel ch;
        ch.projection = JtJ_inv * J.transpose();
        // std_error holds one recording's variance until the end of the constructor.
        for (int q = 0; q < 3; ++q) ch.std_error(q) = std::pow(sigma[static_cast<std::size_t>(c)], 2) * JtJ_inv(kQuantities[q], kQuantities[q]);
        channels_.push_back(std::move(ch));
      }
    }
    // Repeat scatter: the first-order change for one standard deviation of each term (from a tenth
    // of it, where the change is linear), squared.
    const RepeatScatter scatter;
    for (int term = 0; term < 3; ++term) {
      HiddenTruth h{nominal};
      if (term == 0) h.tool.E_Pa *= 1 + 0.1 * scatter.modulus;
      if (term == 1) h.tool.alpha_s *= 1 + 0.1 * scatter.damping;
      if (term == 2) h.tool.load_shift_m = 0.1 * scatter.load_position_m;
      const auto changes = quantityChanges(hiddenResponses(h, daq));
      for (std::size_t k = 0; k < channels_.size(); ++k) channels_[k].std_error += (10 * changes[k]).cwiseAbs2();
    }
    for (Channel& ch : channels_) ch.std_error = (ch.std_error / kRecoveryRepeats).cwiseSqrt();
  }

  // Per weight and channel (weight-major, force first): the first-order change of (A, f_d, zeta).
  std::vector<Eigen::Vector3d> quantityChanges(const std::vector<ChannelResponse>& responses) const {
    std::vector<Eigen::Vector3d> out;
    for (std::size_t w = 0; w < responses.size(); ++w)
      for (int c = 0; c < 2; ++c) {
        const auto& y = c == 0 ? responses[w].force_N : responses[w].deformation_mm;
        const auto& y0 = c == 0 ? nominal_[w].force_N : nominal_[w].deformation_mm;
        const Eigen::VectorXd dy = Eigen::Map<const Eigen::VectorXd>(y.data(), static_cast<Eigen::Index>(y.size())) -
                                   Eigen::Map<const Eigen::VectorXd>(y0.data(), static_cast<Eigen::Index>(y0.size()));
        const Eigen::VectorXd dtheta = channels_[2 * w + static_cast<std::size_t>(c)].projection * dy;
        out.emplace_back(dtheta(kQuantities[0]), dtheta(kQuantities[1]), dtheta(kQuantities[2]));
      }
    return out;
  }

  // max over weights, channels and quantities (steady value, frequency, damping ratio) of
  // |change| / standard error.
  double largestZ(const std::vector<ChannelResponse>& responses) const {
    const auto changes = quantityChanges(responses);
    double z = 0;
    for (std::size_t k = 0; k < changes.size(); ++k) z = std::max(z, changes[k].cwiseAbs().cwiseQuotient(channels_[k].std_error).maxCoeff());
    return z;
  }

  double largestZ(const std::vector<Effect>& effects) const { return largestZ(hiddenResponses(hiddenTruth(effects), daq_)); }

 private:
  static constexpr std::array<int, 3> kQuantities{1, 3, 4};  // A, f_d, zeta of (y0, A, t0, f_d, zeta)
  struct Channel {
    Eigen::MatrixXd projection;  // (J^T J)^-1 J^T
    Eigen::Vector3d std_error;
  };

  static double oneMode(const Eigen::Matrix<double, 5, 1>& p, double t) {
    const double tau = t - p(2);
    if (tau <= 0) return p(0);
    const double zeta = p(4), w_d = 2 * std::numbers::pi * p(3), w_n = w_d / std::sqrt(1 - zeta * zeta);
    return p(0) + p(1) * (1 - std::exp(-zeta * w_n * tau) * (std::cos(w_d * tau) + zeta / std::sqrt(1 - zeta * zeta) * std::sin(w_d * tau)));
  }

  Daq daq_;
  std::vector<ChannelResponse> nominal_;
  std::vector<Channel> channels_;  // weight-major, force then deformation
};

// The largest amount an effect may take (its physical range), or infinity.
inline double amountLimit(int kind, int variant) {
  const std::string id = effectKinds()[static_cast<std::size_t>(kind)].id;
  if (id == "damping_form") return 0.9 * dampingFormLimit(recoveryTool(), variant);
  if (id == "young_modulus" || id == "force_sensor_gain" || id == "deformation_sensor_gain" || id == "load_dependent_modulus")
    return variant == 0 ? 1.0 : 0.9;
  return std::numeric_limits<double>::infinity();
}

// The just-detectable amount of an effect (3 standard errors, file comment), bisected in log
// amount to 0.1 %; cached per process. Throws if the effect stays undetectable over its range.
inline double detectableAmount(int kind, int variant) {
  static std::mutex mutex;
  static std::map<std::pair<int, int>, double> cache;
  {
    const std::lock_guard lock(mutex);
    if (auto it = cache.find({kind, variant}); it != cache.end()) return it->second;
  }
  static const Detectability detectability(recoveryDaq(1));
  const auto z = [&](double a) { return detectability.largestZ(std::vector<Effect>{Effect{kind, variant, a, 1.0}}); };
  const double limit = amountLimit(kind, variant);
  double lo = 1e-6, hi = 1e-6;
  while (z(hi) < 3) {
    if (hi >= std::min(limit, 1e3))
      throw std::runtime_error(std::string("effect ") + effectKinds()[static_cast<std::size_t>(kind)].id + " is not detectable over its range");
    lo = hi, hi = std::min(4 * hi, std::min(limit, 1e3));
  }
  while (hi / lo > 1.001) {
    const double mid = std::sqrt(lo * hi);
    (z(mid) < 3 ? lo : hi) = mid;
  }
  const std::lock_guard lock(mutex);
  cache[{kind, variant}] = hi;
  return hi;
}

enum class DrawClass { Single, Pair, OutsideCatalogue, Null };

inline const char* className(DrawClass c) {
  switch (c) {
    case DrawClass::Single: return "single";
    case DrawClass::Pair: return "pair";
    case DrawClass::OutsideCatalogue: return "outside catalogue";
    case DrawClass::Null: return "null";
  }
  return "";
}

struct Draw {
  int index = 0;
  DrawClass cls = DrawClass::Null;
  std::vector<Effect> effects;
  std::uint64_t noise_seed = 1;

  // e.g. "young_modulus -0.0123 relative (3.1x) + added_mass 0.004 kg (1.7x)", or "none".
  std::string describe() const {
    if (effects.empty()) return "none";
    std::string s;
    for (const Effect& e : effects) {
      char buf[200];
      const bool signed_amount = e.info().variants == 2 && std::string(e.info().id) != "damping_form" && std::string(e.info().id) != "channel_lowpass";
      std::snprintf(buf, sizeof buf, "%s%s %s%.3g %s (%.2fx)%s", s.empty() ? "" : " + ", e.info().id,
                    signed_amount ? (e.variant == 0 ? "+" : "-") : "", e.amount, e.info().amount_unit, e.multiple(),
                    std::string(e.info().id) == "channel_lowpass" ? (e.variant == 0 ? " on force" : " on deformation")
                    : std::string(e.info().id) == "damping_form" ? (e.variant == 0 ? " heavy weight up" : " light weight down")
                                                                   : "");
      s += buf;
    }
    return s;
  }
};

namespace detail {
inline double uniform01(std::mt19937_64& rng) { return static_cast<double>(rng() >> 11) * 0x1.0p-53; }
inline int below(std::mt19937_64& rng, int n) { return static_cast<int>(uniform01(rng) * n); }

inline Effect drawEffect(std::mt19937_64& rng, int kind) {
  Effect e{kind, below(rng, effectKinds()[static_cast<std::size_t>(kind)].variants), 0, 0};
  e.detectable = detectableAmount(e.kind, e.variant);
  const double top = std::min(10.0, amountLimit(e.kind, e.variant) / e.detectable);
  e.amount = e.detectable * std::pow(top, uniform01(rng));  // log-uniform on [1x, top]
  return e;
}
}  // namespace detail

// Draw `index` of the sequence of `master_seed` (file comment).
inline Draw drawCase(std::uint64_t master_seed, int index) {
  std::seed_seq seq{static_cast<std::uint32_t>(master_seed), static_cast<std::uint32_t>(master_seed >> 32), static_cast<std::uint32_t>(index)};
  std::mt19937_64 rng(seq);
  Draw d;
  d.index = index;
  d.noise_seed = rng();
  const int block = index / 5, slot = index % 5;
  const auto catalogue = catalogueKinds();
  const auto n = static_cast<int>(catalogue.size());
  if (slot <= 1) {
    d.cls = DrawClass::Single;
    d.effects.push_back(detail::drawEffect(rng, catalogue[static_cast<std::size_t>((2 * block + slot) % n)]));
  } else if (slot == 2) {
    d.cls = DrawClass::Pair;
    const int first = catalogue[static_cast<std::size_t>(detail::below(rng, n))];
    int second = first;
    while (std::string(effectKinds()[static_cast<std::size_t>(second)].family) == effectKinds()[static_cast<std::size_t>(first)].family)
      second = catalogue[static_cast<std::size_t>(detail::below(rng, n))];
    d.effects.push_back(detail::drawEffect(rng, std::min(first, second)));
    d.effects.push_back(detail::drawEffect(rng, std::max(first, second)));
  } else if (slot == 3) {
    d.cls = DrawClass::OutsideCatalogue;
    const auto outside = outsideKinds();
    d.effects.push_back(detail::drawEffect(rng, outside[static_cast<std::size_t>(block) % outside.size()]));
  }
  return d;
}

// Writes the draw's recordings (w125_r1.csv ... with their sidecars) into `dir`.
// Each repeat draws its scatter (RepeatScatter) from the draw's noise seed.
inline void writeDrawRecordings(const Draw& d, const std::filesystem::path& dir) {
  const Daq daq = recoveryDaq(d.noise_seed);
  const RepeatScatter scatter;
  std::mt19937_64 rng(d.noise_seed ^ 0x5ca77e2ULL);
  std::normal_distribution<double> normal(0.0, 1.0);
  std::filesystem::create_directories(dir);
  for (int repeat = 1; repeat <= kRecoveryRepeats; ++repeat) {
    HiddenTruth h = hiddenTruth(d.effects);
    h.tool.E_Pa *= 1 + scatter.modulus * normal(rng);
    h.tool.alpha_s *= 1 + scatter.damping * normal(rng);
    h.tool.load_shift_m += scatter.load_position_m * normal(rng);
    const auto responses = hiddenResponses(h, daq);
    for (std::size_t w = 0; w < responses.size(); ++w) {
      const double m = recoveryMasses_kg()[w];
      char name[40];
      std::snprintf(name, sizeof name, "w%ld_r%d.csv", std::lround(m * 1000), repeat);
      analysis::writeSyntheticRecording(daqRecording(responses[w], m, daq, repeat), dir / name);
    }
  }
}

}  // namespace demfem::campaign::test

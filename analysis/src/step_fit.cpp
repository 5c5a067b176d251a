// Damped step response fitted by Levenberg-Marquardt (Eigen's unsupported module); the model and
// its contract are in step_fit.hpp.
#include "demfem/analysis/step_fit.hpp"

#include <Eigen/Dense>
#include <unsupported/Eigen/LevenbergMarquardt>

#include <algorithm>
#include <cmath>
#include <numbers>
#include <numeric>
#include <optional>
#include <sstream>

namespace demfem::analysis {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr int kParameters = 5;  // y0, y_ss, t0, w_d, zeta

std::string fmt(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

// Physical parameters of the model (values scaled, see Fitter).
struct Parameters {
  double initial, steady, step_time, omega_d, zeta;
};

// Model value and its gradient in (y0, y_ss, t0, w_d, zeta) at time t.
double modelAndGradient(const Parameters& p, double t, Eigen::Ref<Eigen::RowVectorXd, 0, Eigen::InnerStride<>> gradient) {
  const double tau = t - p.step_time;
  if (tau < 0.0) {
    gradient << 1.0, 0.0, 0.0, 0.0, 0.0;
    return p.initial;
  }
  const double q = std::sqrt(1.0 - p.zeta * p.zeta), r = p.zeta / q;
  const double decay = std::exp(-r * p.omega_d * tau);
  const double c = std::cos(p.omega_d * tau), s = std::sin(p.omega_d * tau);
  const double g = decay * (c + r * s);
  const double amplitude = p.initial - p.steady;
  gradient << g, 1.0 - g, amplitude * decay * s * p.omega_d / (q * q), -amplitude * decay * tau * s / (q * q),
      amplitude * decay / (q * q * q) * (s - tau * p.omega_d * (c + r * s));
  return p.steady + amplitude * g;
}

// Least-squares residuals over samples [0, count) in the unconstrained parameters
// x = (y0, y_ss, t0, ln w_d, logit zeta).
struct Fitter : Eigen::DenseFunctor<double> {
  const Eigen::VectorXd& t;
  const Eigen::VectorXd& y;
  Fitter(const Eigen::VectorXd& time, const Eigen::VectorXd& value, int count)
      : Eigen::DenseFunctor<double>(kParameters, count), t(time), y(value) {}

  static Parameters physical(const Eigen::VectorXd& x) {
    return {x(0), x(1), x(2), std::exp(x(3)), 1.0 / (1.0 + std::exp(-x(4)))};
  }
  int operator()(const Eigen::VectorXd& x, Eigen::VectorXd& residual) const {
    const Parameters p = physical(x);
    Eigen::RowVectorXd gradient(kParameters);
    for (int i = 0; i < values(); ++i) residual(i) = modelAndGradient(p, t(i), gradient) - y(i);
    return 0;
  }
  int df(const Eigen::VectorXd& x, Eigen::MatrixXd& jacobian) const {
    const Parameters p = physical(x);
    for (int i = 0; i < values(); ++i) modelAndGradient(p, t(i), jacobian.row(i));
    jacobian.col(3) *= p.omega_d;                   // d/d ln w_d
    jacobian.col(4) *= p.zeta * (1.0 - p.zeta);     // d/d logit zeta
    return 0;
  }
};

double meanOf(const Eigen::VectorXd& v, Eigen::Index begin, Eigen::Index count) {
  return v.segment(begin, count).mean();
}

// First index i >= from where e crosses `level` in direction `up`, and the interpolated crossing time.
std::optional<double> crossing(const Eigen::VectorXd& t, const Eigen::VectorXd& e, Eigen::Index from, double level, bool up,
                               Eigen::Index& index) {
  for (Eigen::Index i = std::max<Eigen::Index>(from, 1); i < e.size(); ++i) {
    const bool crossed = up ? (e(i - 1) < level && e(i) >= level) : (e(i - 1) > level && e(i) <= level);
    if (!crossed) continue;
    index = i;
    return t(i - 1) + (level - e(i - 1)) / (e(i) - e(i - 1)) * (t(i) - t(i - 1));
  }
  return std::nullopt;
}

// Initial values (header comment): y0 from the first samples, y_ss from the last fifth, zeta from
// the first overshoot, f_d from the first full period between crossings of the steady value (the
// model's crossings are pi / w_d apart), t0 from the first crossing, which the model places at
// w_d tau = pi - atan(sqrt(1 - zeta^2) / zeta).
Eigen::VectorXd initialGuess(const Eigen::VectorXd& t, const Eigen::VectorXd& y, const std::string& what) {
  const Eigen::Index n = y.size();
  const Eigen::Index head = std::max<Eigen::Index>(3, n / 100), tail = n / 5;
  const double y0 = meanOf(y, 0, head), yss = meanOf(y, n - tail, tail);
  const double step = yss - y0;
  if (!(std::abs(step) > 0.0)) throw InputError(what + ": the signal does not step (first and last values agree)");
  const Eigen::VectorXd e = (y.array() - y0) / step;  // 0 before, about 1 after the step
  Eigen::Index peak = 0;
  e.maxCoeff(&peak);
  const double overshoot = e(peak) - 1.0;
  if (!(overshoot > 0.0)) throw InputError(what + ": the response never overshoots its steady value " + fmt(yss) + ": no oscillation to fit");
  const double log_overshoot = std::log(std::min(overshoot, 0.99));
  const double zeta = std::clamp(-log_overshoot / std::sqrt(kPi * kPi + log_overshoot * log_overshoot), 1e-3, 0.9);
  Eigen::Index i_up = 0, i_down = 0, i_next = 0;
  const auto up = crossing(t, e, 1, 1.0, true, i_up);
  const auto down = up ? crossing(t, e, std::max(i_up, peak), 1.0, false, i_down) : std::nullopt;
  const auto next = down ? crossing(t, e, i_down + (i_down - i_up) / 2 + 1, 1.0, true, i_next) : std::nullopt;
  // Without a second crossing the first half period (rise to the peak) has to do.
  const double period = next ? *next - *up : 4.0 * (t(peak) - (up ? *up : t(0)));
  const double omega = 2.0 * kPi / std::max(period, 1e-12);
  const double q = std::sqrt(1.0 - zeta * zeta);
  const double t0 = (up ? *up : t(peak)) - (kPi - std::atan(q / zeta)) / omega;
  Eigen::VectorXd x(kParameters);
  x << y0, yss, t0, std::log(omega), std::log(zeta / (1.0 - zeta));
  return x;
}

}  // namespace

double StepResponseFit::at(double t_s) const {
  Eigen::RowVectorXd gradient(kParameters);
  const Parameters p{initial, steady, step_time_s, 2.0 * kPi * frequency_Hz, damping_ratio};
  return modelAndGradient(p, t_s, gradient);
}

StepResponseFit fitStepResponse(const std::vector<double>& time_s, const std::vector<double>& value, const std::string& what) {
  const std::size_t n = value.size();
  if (time_s.size() != n) throw InputError(what + ": " + std::to_string(time_s.size()) + " times for " + std::to_string(n) + " values");
  if (n < 20) throw InputError(what + ": only " + std::to_string(n) + " samples; a step-response fit needs at least 20");
  // Scaled problem: time from the first sample, values relative to the first and in units of the range.
  const double t_first = time_s.front();
  const auto [lo, hi] = std::minmax_element(value.begin(), value.end());
  const double scale = *hi - *lo > 0.0 ? *hi - *lo : 1.0, offset = value.front();
  Eigen::VectorXd t(static_cast<Eigen::Index>(n)), y(static_cast<Eigen::Index>(n));
  for (std::size_t i = 0; i < n; ++i) {
    t(static_cast<Eigen::Index>(i)) = time_s[i] - t_first;
    y(static_cast<Eigen::Index>(i)) = (value[i] - offset) / scale;
  }
  Eigen::VectorXd x = initialGuess(t, y, what);

  // Fit a growing window (4, 8, 16, ... periods from the step) so a frequency guess off by a few
  // percent cannot lock onto a neighbouring number of cycles over a long record.
  int iterations = 0;
  for (double periods = 4.0;; periods *= 2.0) {
    const double end = x(2) + periods * 2.0 * kPi / std::exp(x(3));
    const auto count = static_cast<int>(std::upper_bound(t.data(), t.data() + t.size(), end) - t.data());
    const int used = std::max(count, std::min<int>(static_cast<int>(n), 4 * kParameters));
    Fitter fitter(t, y, used);
    Eigen::LevenbergMarquardt<Fitter> lm(fitter);
    lm.setMaxfev(2000);
    const auto status = lm.minimize(x);
    iterations += static_cast<int>(lm.iterations());
    if (status == Eigen::LevenbergMarquardtSpace::ImproperInputParameters || !x.allFinite())
      throw InputError(what + ": the step-response fit did not converge");
    if (used == static_cast<int>(n)) break;
  }

  const Parameters p = Fitter::physical(x);
  Eigen::MatrixXd jacobian(static_cast<Eigen::Index>(n), kParameters);
  double sum_sq = 0.0;
  for (Eigen::Index i = 0; i < t.size(); ++i) {
    const double r = modelAndGradient(p, t(i), jacobian.row(i)) - y(i);
    sum_sq += r * r;
  }
  const double rms = std::sqrt(sum_sq / static_cast<double>(n - kParameters));
  if (!(std::abs(p.steady - p.initial) > 3.0 * rms))
    throw InputError(what + ": the fitted step " + fmt(scale * (p.steady - p.initial)) + " is within the noise (" + fmt(scale * rms) + ")");
  const double fitted_overshoot = std::abs(p.steady - p.initial) * std::exp(-kPi * p.zeta / std::sqrt(1.0 - p.zeta * p.zeta));
  if (!(fitted_overshoot > 3.0 * rms))
    throw InputError(what + ": the response never overshoots its steady value " + fmt(offset + scale * p.steady) +
                     " by more than the noise (" + fmt(scale * rms) + "): no oscillation to fit");
  const Eigen::MatrixXd covariance = (jacobian.transpose() * jacobian).inverse() * (rms * rms);

  StepResponseFit fit;
  fit.initial = offset + scale * p.initial;
  fit.steady = offset + scale * p.steady;
  fit.step_time_s = t_first + p.step_time;
  fit.frequency_Hz = p.omega_d / (2.0 * kPi);
  fit.damping_ratio = p.zeta;
  fit.natural_frequency_Hz = fit.frequency_Hz / std::sqrt(1.0 - p.zeta * p.zeta);
  fit.residual_rms = scale * rms;
  fit.steady_error = scale * std::sqrt(covariance(1, 1));
  fit.frequency_error_Hz = std::sqrt(covariance(3, 3)) / (2.0 * kPi);
  fit.damping_ratio_error = std::sqrt(covariance(4, 4));
  fit.samples = n;
  fit.iterations = iterations;
  return fit;
}

}  // namespace demfem::analysis

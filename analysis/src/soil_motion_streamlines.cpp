// Streamlines of a flow section and their statistics (soil_motion.hpp, traceStreamlines(),
// streamlineStatistics(); docs/analysis.md, "Soil motion").
#include "demfem/analysis/recording.hpp"
#include "demfem/analysis/soil_motion.hpp"
#include "soil_motion_median.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace demfem::analysis {

namespace {

struct Vec2 {
  double u = 0, v = 0;
};

Vec2 operator+(Vec2 a, Vec2 b) { return {a.u + b.u, a.v + b.v}; }
Vec2 operator*(double s, Vec2 a) { return {s * a.u, s * a.v}; }
double norm(Vec2 a) { return std::hypot(a.u, a.v); }

// The cells in motion of a flow section and the interpolated field over them.
class Field {
 public:
  explicit Field(const FlowSection& flow) : map_(flow.velocity_u), flow_(flow) {
    for (std::size_t k = 0; k < map_.values.size(); ++k)
      moving_.push_back(std::isfinite(flow.velocity_u.values[k]) &&
                        std::hypot(flow.velocity_u.values[k], flow.velocity_v.values[k]) > flow.threshold_m_s);
  }

  bool moving(int iu, int iv) const { return iu >= 0 && iv >= 0 && iu < map_.nu && iv < map_.nv && moving_[index(iu, iv)]; }

  // Inside the region: the point's cell is in motion.
  bool inside(Vec2 p) const {
    return moving(static_cast<int>(std::floor((p.u - map_.u0_m) / map_.cell_m)), static_cast<int>(std::floor((p.v - map_.v0_m) / map_.cell_m)));
  }

  // Bilinear interpolation of the cell-centre velocities over the surrounding cells in motion
  // (weights renormalised); only called inside the region, where the point's own cell weighs >= 1/4.
  Vec2 velocity(Vec2 p) const {
    const double fu = (p.u - map_.u0_m) / map_.cell_m - 0.5, fv = (p.v - map_.v0_m) / map_.cell_m - 0.5;
    const int iu = static_cast<int>(std::floor(fu)), iv = static_cast<int>(std::floor(fv));
    const double tu = fu - iu, tv = fv - iv;
    Vec2 sum;
    double weight = 0;
    for (int du = 0; du < 2; ++du)
      for (int dv = 0; dv < 2; ++dv) {
        if (!moving(iu + du, iv + dv)) continue;
        const double w = (du ? tu : 1 - tu) * (dv ? tv : 1 - tv);
        const std::size_t k = index(iu + du, iv + dv);
        sum = sum + w * Vec2{flow_.velocity_u.values[k], flow_.velocity_v.values[k]};
        weight += w;
      }
    return (1.0 / weight) * sum;
  }

  const SectionMap& map() const { return map_; }
  double threshold() const { return flow_.threshold_m_s; }

 private:
  std::size_t index(int iu, int iv) const { return static_cast<std::size_t>(iv) * map_.nu + iu; }

  const SectionMap& map_;
  const FlowSection& flow_;
  std::vector<bool> moving_;
};

double angleBetween(Vec2 a, Vec2 b) { return std::atan2(std::fabs(a.u * b.v - a.v * b.u), a.u * b.u + a.v * b.v); }

// The last point of the straight step from p along d (length h) still inside the region.
Vec2 boundaryOnStep(const Field& field, Vec2 p, Vec2 d, double h) {
  double in = 0, out = h;
  for (int i = 0; i < 50; ++i) {
    const double mid = 0.5 * (in + out);
    (field.inside(p + mid * d) ? in : out) = mid;
  }
  return p + in * d;
}

struct Direction {
  std::vector<Vec2> points;   // after the seed
  bool stepped = false;
  Vec2 first;                 // the direction of the first step, when stepped
  double length_m = 0, turning_rad = 0;
};

// One direction (sign +1 along the flow, -1 against) from the seed; `previous` (when `arriving`) is
// the direction the line arrives with at the seed (the other half's first step, reversed), `budget`
// the turning left.
Direction trace(const Field& field, Vec2 seed, double sign, bool arriving, Vec2 previous, double budget, const StreamlineRules& rules) {
  const double h = rules.step_fraction * field.map().cell_m;
  const auto unit = [&](Vec2 v) { return (sign / norm(v)) * v; };
  Direction out;
  Vec2 p = seed;
  for (;;) {
    const Vec2 v = field.velocity(p);
    if (!(norm(v) > field.threshold())) return out;
    const Vec2 mid = p + (0.5 * h) * unit(v);
    if (!field.inside(mid) || !(norm(field.velocity(mid)) > field.threshold())) return out;
    const Vec2 d = unit(field.velocity(mid));
    if (arriving) {
      const double turn = angleBetween(previous, d);
      if (turn > rules.max_step_turn_rad || out.turning_rad + turn > budget) return out;
      out.turning_rad += turn;
    }
    if (!out.stepped) out.first = d;
    out.stepped = true;
    const Vec2 next = p + h * d;
    if (!field.inside(next)) {
      const Vec2 edge = boundaryOnStep(field, p, d, h);
      out.length_m += norm(edge + (-1.0) * p);
      out.points.push_back(edge);
      return out;
    }
    out.points.push_back(next);
    out.length_m += h;
    arriving = true;
    previous = d;
    p = next;
  }
}

Streamline streamlineFrom(const Field& field, Vec2 seed, const StreamlineRules& rules) {
  const Direction ahead = trace(field, seed, 1.0, false, {}, rules.max_total_turn_rad, rules);
  const Direction behind = trace(field, seed, -1.0, ahead.stepped, (-1.0) * ahead.first, rules.max_total_turn_rad - ahead.turning_rad, rules);
  Streamline line;
  line.seed_u_m = seed.u;
  line.seed_v_m = seed.v;
  for (auto it = behind.points.rbegin(); it != behind.points.rend(); ++it) {
    line.u_m.push_back(it->u);
    line.v_m.push_back(it->v);
  }
  line.u_m.push_back(seed.u);
  line.v_m.push_back(seed.v);
  for (const Vec2& q : ahead.points) {
    line.u_m.push_back(q.u);
    line.v_m.push_back(q.v);
  }
  line.length_m = ahead.length_m + behind.length_m;
  line.turning_rad = ahead.turning_rad + behind.turning_rad;
  return line;
}

}  // namespace

std::vector<Streamline> traceStreamlines(const FlowSection& flow, const StreamlineRules& rules) {
  if (!(rules.step_fraction > 0 && rules.step_fraction <= 1)) throw InputError("streamlines: the step fraction of the cell must be in (0, 1]");
  if (!(rules.max_step_turn_rad > 0) || !(rules.max_total_turn_rad > 0)) throw InputError("streamlines: the turning limits must be > 0");
  const Field field(flow);
  const SectionMap& map = field.map();
  std::vector<Streamline> lines;
  for (int iv = 0; iv < map.nv; ++iv)
    for (int iu = 0; iu < map.nu; ++iu)
      if (field.moving(iu, iv))
        lines.push_back(streamlineFrom(field, {map.u0_m + (iu + 0.5) * map.cell_m, map.v0_m + (iv + 0.5) * map.cell_m}, rules));
  return lines;
}

StreamlineStatistics streamlineStatistics(const std::vector<Streamline>& lines) {
  StreamlineStatistics s;
  s.count = lines.size();
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (lines.empty()) {
    s.mean_length_m = s.median_length_m = s.curvature_rad_per_m = nan;
    return s;
  }
  std::vector<double> lengths;
  double turning = 0;
  for (const auto& l : lines) {
    lengths.push_back(l.length_m);
    turning += l.turning_rad;
  }
  std::sort(lengths.begin(), lengths.end());
  double total = 0;
  for (const double l : lengths) total += l;
  s.mean_length_m = total / static_cast<double>(lengths.size());
  s.median_length_m = medianOfSorted(lengths);
  s.curvature_rad_per_m = total > 0 ? turning / total : nan;
  return s;
}

}  // namespace demfem::analysis

#include "demfem/analysis/soil_motion.hpp"

#include "demfem/analysis/recording.hpp"
#include "demfem/vtkio/vtk_files.hpp"
#include "soil_motion_median.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <fstream>
#include <limits>
#include <map>
#include <set>

namespace demfem::analysis {

namespace {

namespace fs = std::filesystem;

double entropy(const std::map<int, std::size_t>& counts, std::size_t total) {
  double h = 0;
  for (const auto& [label, n] : counts) {
    const double p = static_cast<double>(n) / static_cast<double>(total);
    h -= p * std::log(p);
  }
  return h;
}

Box boundsOf(const std::vector<double>& xyz) {
  Box b;
  for (int c = 0; c < 3; ++c) {
    b.lo[c] = std::numeric_limits<double>::infinity();
    b.hi[c] = -std::numeric_limits<double>::infinity();
  }
  for (std::size_t i = 0; i < xyz.size() / 3; ++i)
    for (int c = 0; c < 3; ++c) {
      b.lo[c] = std::min(b.lo[c], xyz[3 * i + c]);
      b.hi[c] = std::max(b.hi[c], xyz[3 * i + c]);
    }
  return b;
}

const vtkio::PointArray& requiredArray(const vtkio::Dataset& d, const std::string& name, int components, const fs::path& file) {
  try {
    const auto& a = d.array(name);
    if (a.components != components) throw InputError(file.string() + ": point array '" + name + "' has " + std::to_string(a.components) +
                                                     " components, expected " + std::to_string(components));
    return a;
  } catch (const vtkio::VtkError& e) {
    throw InputError(file.string() + ": " + e.what());
  }
}

std::vector<vtkio::CollectionEntry> collection(const fs::path& pvd) {
  try {
    return vtkio::readCollection(pvd);
  } catch (const vtkio::VtkError& e) {
    throw InputError(e.what());
  }
}

// The DEM tool collection of the run: `tool`'s, or the only one.
fs::path toolCollection(const fs::path& vtk_dir, std::string& tool) {
  if (!tool.empty()) return vtk_dir / ("dem-" + tool + ".pvd");
  std::vector<std::string> found;
  if (fs::is_directory(vtk_dir))
    for (const auto& entry : fs::directory_iterator(vtk_dir)) {
      const std::string name = entry.path().filename().string();
      if (name.rfind("dem-", 0) == 0 && entry.path().extension() == ".pvd") found.push_back(name.substr(4, name.size() - 8));
    }
  std::sort(found.begin(), found.end());
  if (found.size() != 1) {
    std::string names;
    for (const auto& f : found) names += (names.empty() ? "" : ", ") + f;
    throw InputError(vtk_dir.string() + ": " + (found.empty() ? std::string("no DEM tool collection dem-TOOL.pvd")
                                                               : "several tools (" + names + "): choose one"));
  }
  tool = found.front();
  return vtk_dir / ("dem-" + tool + ".pvd");
}

// A run marked incomplete by its sidecar (DIR/sensors.json, "complete": false) is refused: its
// particle files stop where the run failed. No sidecar (particle tracks from elsewhere): nothing to check.
void refuseIncompleteRun(const fs::path& run_dir) {
  const fs::path sidecar = run_dir / "sensors.json";
  if (!fs::exists(sidecar)) return;
  std::ifstream in(sidecar);
  const nlohmann::json doc = nlohmann::json::parse(in, nullptr, false);
  if (doc.is_discarded() || !doc.is_object()) throw InputError(sidecar.string() + ": not a JSON object");
  if (!doc.contains("complete") || !doc["complete"].is_boolean()) throw InputError(sidecar.string() + ": /complete: missing or not true/false");
  if (!doc["complete"].get<bool>())
    throw InputError(sidecar.string() + ": /complete: the run is marked incomplete (complete: false" +
                     (doc.contains("incomplete_reason") && doc["incomplete_reason"].is_string() ? ", " + doc["incomplete_reason"].get<std::string>()
                                                                                               : std::string()) +
                     "): its particle files stop where it failed");
}

}  // namespace

double ParticleFrame::speed(std::size_t i) const {
  return std::hypot(velocity_m_s[3 * i], velocity_m_s[3 * i + 1], velocity_m_s[3 * i + 2]);
}

bool Box::contains(const double* p) const {
  for (int c = 0; c < 3; ++c)
    if (p[c] < lo[c] || p[c] > hi[c]) return false;
  return true;
}

Box ToolFrame::bounds() const { return boundsOf(node_m); }

namespace {

// An empty map over the frame's centres on the axes (u_axis, v_axis) with cells of `cell`.
SectionMap emptyMap(const ParticleFrame& frame, Axis axis, int u_axis, int v_axis, double cell_m) {
  if (!(cell_m > 0)) throw InputError("section map: the cell size must be > 0");
  if (frame.size() == 0) throw InputError("section map: the frame has no particles");
  SectionMap map;
  map.axis = axis;
  map.cell_m = cell_m;
  const Box all = boundsOf(frame.position_m);
  map.u0_m = all.lo[u_axis];
  map.v0_m = all.lo[v_axis];
  map.nu = 1 + static_cast<int>(std::floor((all.hi[u_axis] - map.u0_m) / cell_m + 1e-9));
  map.nv = 1 + static_cast<int>(std::floor((all.hi[v_axis] - map.v0_m) / cell_m + 1e-9));
  map.values.assign(static_cast<std::size_t>(map.nu) * map.nv, std::numeric_limits<double>::quiet_NaN());
  return map;
}

std::size_t cellOf(const SectionMap& map, const double* p, int u_axis, int v_axis) {
  const int iu = std::min(map.nu - 1, static_cast<int>(std::floor((p[u_axis] - map.u0_m) / map.cell_m + 1e-9)));
  const int iv = std::min(map.nv - 1, static_cast<int>(std::floor((p[v_axis] - map.v0_m) / map.cell_m + 1e-9)));
  return static_cast<std::size_t>(iv) * map.nu + iu;
}

}  // namespace

namespace {

struct SectionAxes {
  int normal, u, v;  // frame components: the plane's normal, the map's u and v axes
};

SectionAxes axesOf(Axis axis) {
  switch (axis) {
    case Axis::X: return {0, 2, 1};
    case Axis::Y: return {1, 2, 0};
  }
  throw InputError("section: unknown axis");
}

// The empty map of a section (velocitySection()'s plane, thickness and cells).
SectionMap sectionGrid(const ParticleFrame& frame, Axis axis, double position_m, double half_thickness_m, double cell_m) {
  if (!(half_thickness_m > 0)) throw InputError("velocity section: the half thickness must be > 0");
  const SectionAxes a = axesOf(axis);
  SectionMap map = emptyMap(frame, axis, a.u, a.v, cell_m);
  map.position_m = position_m;
  map.half_thickness_m = half_thickness_m;
  return map;
}

// visit(particle, cell) for every particle centred within the section's half thickness of its plane.
template <class Visit>
void forEachOnSection(const ParticleFrame& frame, const SectionMap& map, Visit&& visit) {
  const SectionAxes a = axesOf(map.axis);
  for (std::size_t i = 0; i < frame.size(); ++i) {
    const double* p = &frame.position_m[3 * i];
    if (std::fabs(p[a.normal] - map.position_m) <= map.half_thickness_m) visit(i, cellOf(map, p, a.u, a.v));
  }
}

}  // namespace

SectionMap velocitySection(const ParticleFrame& frame, Axis axis, double position_m, double half_thickness_m, double cell_m) {
  SectionMap map = sectionGrid(frame, axis, position_m, half_thickness_m, cell_m);
  std::vector<double> sum(map.values.size(), 0.0);
  std::vector<std::size_t> count(sum.size(), 0);
  forEachOnSection(frame, map, [&](std::size_t i, std::size_t k) {
    sum[k] += frame.speed(i);
    ++count[k];
  });
  for (std::size_t k = 0; k < sum.size(); ++k)
    if (count[k]) map.values[k] = sum[k] / static_cast<double>(count[k]);
  return map;
}

FlowSection flowSection(const ParticleFrame& frame, Axis axis, double position_m, double half_thickness_m, double cell_m,
                        double threshold_m_s) {
  if (!(threshold_m_s >= 0)) throw InputError("flow section: the speed threshold must be >= 0");
  FlowSection flow;
  flow.threshold_m_s = threshold_m_s;
  flow.velocity_u = sectionGrid(frame, axis, position_m, half_thickness_m, cell_m);
  flow.velocity_v = flow.alignment = flow.velocity_u;
  const std::size_t cells = flow.velocity_u.values.size();
  const SectionAxes a = axesOf(axis);
  std::vector<double> su(cells, 0.0), sv(cells, 0.0);
  std::vector<std::size_t> count(cells, 0);
  std::vector<std::array<double, 3>> unit(cells, {0.0, 0.0, 0.0});
  flow.moving.assign(cells, 0);
  forEachOnSection(frame, flow.velocity_u, [&](std::size_t i, std::size_t k) {
    const double* v = &frame.velocity_m_s[3 * i];
    su[k] += v[a.u];
    sv[k] += v[a.v];
    ++count[k];
    const double speed = frame.speed(i);
    if (!(speed > threshold_m_s)) return;
    for (int c = 0; c < 3; ++c) unit[k][c] += v[c] / speed;
    ++flow.moving[k];
  });
  for (std::size_t k = 0; k < cells; ++k) {
    if (count[k]) {
      flow.velocity_u.values[k] = su[k] / static_cast<double>(count[k]);
      flow.velocity_v.values[k] = sv[k] / static_cast<double>(count[k]);
    }
    if (flow.moving[k] >= 2) flow.alignment.values[k] = std::hypot(unit[k][0], unit[k][1], unit[k][2]) / static_cast<double>(flow.moving[k]);
  }
  return flow;
}

AlignmentOrder alignmentOrder(const FlowSection& flow) {
  AlignmentOrder o;
  double order = 0, baseline = 0;
  for (std::size_t k = 0; k < flow.moving.size(); ++k) {
    const double n = static_cast<double>(flow.moving[k]);
    if (flow.moving[k] < 2) continue;
    ++o.cells;
    o.particles += flow.moving[k];
    order += n * flow.alignment.values[k];
    baseline += n / std::sqrt(n);
  }
  const double nan = std::numeric_limits<double>::quiet_NaN();
  o.order = o.cells ? order / static_cast<double>(o.particles) : nan;
  o.random_baseline = o.cells ? baseline / static_cast<double>(o.particles) : nan;
  return o;
}

SectionMap mixingSection(const ParticleFrame& frame, double cell_m) {
  SectionMap map = emptyMap(frame, Axis::X, 2, 1, cell_m);
  std::vector<std::map<int, std::size_t>> cells(map.values.size());
  std::map<int, std::size_t> labels;
  for (std::size_t i = 0; i < frame.size(); ++i) {
    ++cells[cellOf(map, &frame.position_m[3 * i], 2, 1)][frame.layer[i]];
    ++labels[frame.layer[i]];
  }
  const double total = entropy(labels, frame.size());
  for (std::size_t k = 0; k < cells.size(); ++k) {
    std::size_t n = 0;
    for (const auto& [label, c] : cells[k]) n += c;
    if (n) map.values[k] = total > 0 ? entropy(cells[k], n) / total : 0.0;
  }
  return map;
}

namespace {

// The extent of the spheres `members` of `frame` (movingExtent()).
MovingExtent extentOf(const ParticleFrame& frame, const std::vector<std::size_t>& members, double threshold_m_s, double surface_y_m) {
  MovingExtent e;
  e.threshold_m_s = threshold_m_s;
  e.count = members.size();
  if (members.empty()) return e;
  std::vector<double> extremes;  // lowest and highest points of every sphere
  for (const std::size_t i : members)
    for (const double s : {-1.0, 1.0})
      for (int c = 0; c < 3; ++c) extremes.push_back(frame.position_m[3 * i + c] + s * frame.radius_m[i]);
  e.region = boundsOf(extremes);
  e.depth_m = surface_y_m - e.region.lo[1];
  e.length_m = e.region.hi[2] - e.region.lo[2];
  e.width_m = e.region.hi[0] - e.region.lo[0];
  return e;
}

std::vector<std::size_t> fastParticles(const ParticleFrame& frame, double threshold_m_s) {
  std::vector<std::size_t> fast;
  for (std::size_t i = 0; i < frame.size(); ++i)
    if (frame.speed(i) > threshold_m_s) fast.push_back(i);
  return fast;
}

// The members of `fast` connected to a seed (connectedMovingExtent()), by a breadth-first search
// over a grid of cells no smaller than the longest link (2 r_max + gap).
std::vector<std::size_t> connectedTo(const ParticleFrame& frame, const std::vector<std::size_t>& fast, const Box& seed, double gap_m) {
  double r_max = 0;
  for (const std::size_t i : fast) r_max = std::max(r_max, frame.radius_m[i]);
  const double cell = 2 * r_max + gap_m;
  using Key = std::array<long long, 3>;
  const auto keyOf = [&](std::size_t i) {
    Key k;
    for (int c = 0; c < 3; ++c) k[c] = static_cast<long long>(std::floor(frame.position_m[3 * i + c] / cell));
    return k;
  };
  std::map<Key, std::vector<std::size_t>> grid;
  for (const std::size_t i : fast) grid[keyOf(i)].push_back(i);
  std::set<std::size_t> reached;
  std::vector<std::size_t> queue;
  for (const std::size_t i : fast)
    if (seed.contains(&frame.position_m[3 * i]) && reached.insert(i).second) queue.push_back(i);
  for (std::size_t head = 0; head < queue.size(); ++head) {
    const std::size_t i = queue[head];
    const Key k = keyOf(i);
    for (long long dx = -1; dx <= 1; ++dx)
      for (long long dy = -1; dy <= 1; ++dy)
        for (long long dz = -1; dz <= 1; ++dz) {
          const auto it = grid.find({k[0] + dx, k[1] + dy, k[2] + dz});
          if (it == grid.end()) continue;
          for (const std::size_t j : it->second) {
            if (reached.count(j)) continue;
            const double* a = &frame.position_m[3 * i];
            const double* b = &frame.position_m[3 * j];
            const double d = std::sqrt((a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]));
            if (d - frame.radius_m[i] - frame.radius_m[j] <= gap_m) reached.insert(j), queue.push_back(j);
          }
        }
  }
  return queue;
}

}  // namespace

MovingExtent movingExtent(const ParticleFrame& frame, double threshold_m_s, double surface_y_m) {
  return extentOf(frame, fastParticles(frame, threshold_m_s), threshold_m_s, surface_y_m);
}

MovingExtent connectedMovingExtent(const ParticleFrame& frame, double threshold_m_s, double surface_y_m, const Box& seed, double gap_m) {
  return extentOf(frame, connectedTo(frame, fastParticles(frame, threshold_m_s), seed, gap_m), threshold_m_s, surface_y_m);
}

SpeedRange frontVelocityRange(const ParticleFrame& frame, const Box& box) {
  std::vector<double> speeds;
  for (std::size_t i = 0; i < frame.size(); ++i)
    if (box.contains(&frame.position_m[3 * i])) speeds.push_back(frame.speed(i));
  SpeedRange r;
  r.count = speeds.size();
  if (speeds.empty()) return r;
  std::sort(speeds.begin(), speeds.end());
  r.min_m_s = speeds.front();
  r.max_m_s = speeds.back();
  r.median_m_s = medianOfSorted(speeds);
  return r;
}

std::vector<double> layerBoundaries(const ParticleFrame& frame) {
  std::map<int, std::pair<double, double>> span;  // layer -> lowest, highest centre
  for (std::size_t i = 0; i < frame.size(); ++i) {
    const double y = frame.position_m[3 * i + 1];
    auto [it, inserted] = span.try_emplace(frame.layer[i], y, y);
    it->second.first = std::min(it->second.first, y);
    it->second.second = std::max(it->second.second, y);
  }
  std::vector<double> out;
  for (auto it = span.begin(); it != span.end() && std::next(it) != span.end(); ++it)
    out.push_back(0.5 * (it->second.first + std::next(it)->second.second));
  return out;
}

double mixingIndex(const ParticleFrame& frame, double cell_m, const std::vector<double>& boundaries_y_m) {
  if (!(cell_m > 0)) throw InputError("mixing index: the cell size must be > 0");
  if (frame.size() == 0) return 0;
  std::vector<double> cuts = boundaries_y_m;
  std::sort(cuts.begin(), cuts.end());
  const Box all = boundsOf(frame.position_m);
  std::map<std::array<long, 3>, std::map<int, std::size_t>> cells;
  std::map<int, std::size_t> labels;
  for (std::size_t i = 0; i < frame.size(); ++i) {
    const double* p = &frame.position_m[3 * i];
    const long slab = std::upper_bound(cuts.begin(), cuts.end(), p[1]) - cuts.begin();
    const std::array<long, 3> key{std::lround(std::floor((p[0] - all.lo[0]) / cell_m)), slab,
                                  std::lround(std::floor((p[2] - all.lo[2]) / cell_m))};
    ++cells[key][frame.layer[i]];
    ++labels[frame.layer[i]];
  }
  const double total = entropy(labels, frame.size());
  if (total <= 0) return 0;
  double conditional = 0;
  for (const auto& [key, counts] : cells) {
    std::size_t n = 0;
    for (const auto& [label, c] : counts) n += c;
    conditional += static_cast<double>(n) / static_cast<double>(frame.size()) * entropy(counts, n);
  }
  return conditional / total;
}

ParticleFrame readParticleFrame(const fs::path& file) {
  vtkio::Dataset d;
  try {
    d = vtkio::read(file);
  } catch (const vtkio::VtkError& e) {
    throw InputError(e.what());
  }
  ParticleFrame f;
  f.time_s = d.time_s;
  f.position_m = std::move(d.points);
  f.velocity_m_s = requiredArray(d, "velocity_m_s", 3, file).values;
  f.radius_m = requiredArray(d, "radius_m", 1, file).values;
  for (const double l : requiredArray(d, "layer", 1, file).values) f.layer.push_back(static_cast<int>(std::lround(l)));
  return f;
}

RunFrames loadRun(const fs::path& run_dir, const std::string& tool) {
  RunFrames run;
  run.directory = run_dir;
  run.tool = tool;
  refuseIncompleteRun(run_dir);
  const fs::path vtk_dir = run_dir / "vtk";
  const auto particles = collection(vtk_dir / "particles.pvd");
  const auto tools = collection(toolCollection(vtk_dir, run.tool));
  if (particles.empty()) throw InputError((vtk_dir / "particles.pvd").string() + ": lists no particle file");
  for (const auto& entry : particles) {
    const auto match = std::find_if(tools.begin(), tools.end(), [&](const auto& t) { return std::fabs(t.time_s - entry.time_s) <= 1e-9; });
    if (match == tools.end())
      throw InputError((vtk_dir / ("dem-" + run.tool + ".pvd")).string() + ": no tool file at t = " + std::to_string(entry.time_s) +
                       " s, the time of " + entry.file.string());
    vtkio::Dataset surface;
    try {
      surface = vtkio::read(match->file);
    } catch (const vtkio::VtkError& e) {
      throw InputError(e.what());
    }
    run.time_s.push_back(entry.time_s);
    run.particle_files.push_back(entry.file);
    run.tool_frames.push_back({surface.time_s, std::move(surface.points)});
  }
  return run;
}

double toolDisplacement(const RunFrames& run, std::size_t frame) {
  const auto meanZ = [](const ToolFrame& t) {
    double z = 0;
    for (std::size_t i = 2; i < t.node_m.size(); i += 3) z += t.node_m[i];
    return z / static_cast<double>(t.node_m.size() / 3);
  };
  return meanZ(run.tool_frames.at(frame)) - meanZ(run.tool_frames.front());
}

ParticleFrame againstRest(const ParticleFrame& frame, const ParticleFrame& rest, const fs::path& rest_file) {
  if (rest.size() != frame.size())
    throw InputError(rest_file.string() + ": the rest run has " + std::to_string(rest.size()) + " particles, the run " +
                     std::to_string(frame.size()) + ": not the same bed");
  ParticleFrame out = frame;
  for (std::size_t i = 0; i < frame.size(); ++i) {
    if (rest.radius_m[i] != frame.radius_m[i])
      throw InputError(rest_file.string() + ": particle " + std::to_string(i) + " has radius " + std::to_string(rest.radius_m[i] * 1e3) +
                       " mm in the rest run, " + std::to_string(frame.radius_m[i] * 1e3) + " mm in the run: not the same bed");
    for (int c = 0; c < 3; ++c) out.velocity_m_s[3 * i + c] -= rest.velocity_m_s[3 * i + c];
  }
  return out;
}

fs::path restFrameAt(const fs::path& rest_dir, double time_s) {
  const fs::path pvd = rest_dir / "vtk" / "particles.pvd";
  for (const auto& entry : collection(pvd))
    if (std::fabs(entry.time_s - time_s) <= 1e-6) return entry.file;
  throw InputError(pvd.string() + ": no particle file at t = " + std::to_string(time_s) +
                   " s: the rest run must have a frame at every analysed time of the run");
}

}  // namespace demfem::analysis

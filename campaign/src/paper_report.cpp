// docs/paper-reproduction.md from campaign runs, beside the paper's stated numbers
// (campaign/paper_report.hpp).
#include "demfem/campaign/paper_report.hpp"

#include "demfem/analysis/evaluation.hpp"
#include "demfem/analysis/recording.hpp"
#include "demfem/analysis/report_section.hpp"
#include "demfem/analysis/soil_motion_report.hpp"
#include "demfem/analysis/spectrum.hpp"
#include "demfem/backends/physics/time_step.hpp"
#include "demfem/study/tool_motion.hpp"
#include "demfem/campaign/paper_campaign.hpp"
#include "demfem/campaign/parameters.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <sstream>

namespace demfem::campaign {

namespace fs = std::filesystem;

namespace {

constexpr double kPaperStrokeMm = 600;  // Section 2.9
// Section 2.3 / Fig. 15: the statistics window; Section 3: the tilt window (mm of displacement).
constexpr double kWindowBeginMm = 100, kWindowEndMm = 500, kTiltBeginMm = 200, kTiltEndMm = 400;
constexpr double kFitLowHz = 1.0;
constexpr double kSoilMotionAtMm = 300;  // Section 3.5, Fig. 16
// What a report keeps of each evaluation (see contract): the curve at one sample per
// kCurveStepMm, the spectrum as means over kSpectrumBinsPerDecade logarithmic bins per decade.
constexpr const char* kKeptDirectory = "paper-runs";
constexpr double kCurveStepMm = 0.5;
constexpr double kSpectrumBinsPerDecade = 50;

struct Evaluated : RunEvaluation {
  double run_estimate_s = 0;
  std::string label;  // the runs' label, ReportOptions::label of the report that evaluated it
  bool kept = false;  // taken from an earlier report's kept evaluation
};

struct ReportCase {
  std::string name;
  study::Study study;
  const PaperCase* paper = nullptr;
  double full_estimate_s = 0;
  std::optional<Evaluated> run;
  bool kept_stale = false;  // a kept evaluation of another version of the study was not used
  // Without a run: measured / estimated wall time of the finished runs of its model (DEM-FEM or
  // DEM), and how many there are (0: the estimate stands as it is).
  double cost_ratio = 1;
  int cost_ratio_runs = 0;
};

std::string kindName(study::StudyKind kind) { return kind == study::StudyKind::DemOnly ? "DEM" : "DEM-FEM"; }

std::optional<std::pair<double, double>> rangeIn(const std::vector<double>& x, const std::vector<double>& v, double lo, double hi) {
  std::optional<std::pair<double, double>> r;
  for (std::size_t i = 0; i < x.size() && i < v.size(); ++i) {
    if (x[i] < lo || x[i] > hi) continue;
    if (!r) r = std::pair{v[i], v[i]};
    r->first = std::min(r->first, v[i]);
    r->second = std::max(r->second, v[i]);
  }
  return r;
}

// The curve at one sample per kCurveStepMm of displacement (the first sample of each step).
analysis::DisplacementCurve thinned(const analysis::DisplacementCurve& c) {
  analysis::DisplacementCurve t;
  double next_mm = -std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < c.size(); ++i) {
    if (c.displacement_mm[i] < next_mm) continue;
    next_mm = c.displacement_mm[i] + kCurveStepMm;
    t.time_s.push_back(c.time_s[i]);
    t.displacement_mm.push_back(c.displacement_mm[i]);
    t.force_N.push_back(c.force_N[i]);
    t.deformation_mm.push_back(c.deformation_mm[i]);
    if (!c.tilt_deg.empty()) t.tilt_deg.push_back(c.tilt_deg[i]);
  }
  return t;
}

// The spectrum from kFitLowHz up as the means (of frequency and amplitude) over logarithmic bins.
analysis::Spectrum binned(const analysis::Spectrum& s) {
  analysis::Spectrum b;
  b.sample_rate_Hz = s.sample_rate_Hz, b.samples_used = s.samples_used;
  double f_sum = 0, a_sum = 0;
  int members = 0;
  long bin = std::numeric_limits<long>::min();
  auto flush = [&] {
    if (members == 0) return;
    b.frequency_Hz.push_back(f_sum / members);
    b.amplitude.push_back(a_sum / members);
    f_sum = a_sum = 0, members = 0;
  };
  for (std::size_t i = 0; i < s.frequency_Hz.size(); ++i) {
    const double f = s.frequency_Hz[i];
    if (f < kFitLowHz) continue;
    const auto k = static_cast<long>(std::floor(std::log10(f) * kSpectrumBinsPerDecade));
    if (k != bin) flush(), bin = k;
    f_sum += f, a_sum += s.amplitude[i], ++members;
  }
  flush();
  return b;
}

std::string studyHash(const study::Study& s) {
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(study::fnv1a64(caseIdentity(s))));
  return hex;
}

// A sample of a kept curve or spectrum, to 7 significant digits (a kept file stays small and reads
// back to the number it was written from).
double rounded(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%.7g", v);
  return std::strtod(text, nullptr);
}

nlohmann::json roundedArray(const std::vector<double>& v) {
  nlohmann::json a = nlohmann::json::array();
  for (double x : v) a.push_back(rounded(x));
  return a;
}

// A number that may be NaN (no value) as JSON null, and back.
nlohmann::json orNull(double v) { return std::isnan(v) ? nlohmann::json(nullptr) : nlohmann::json(v); }
double numberOrNaN(const nlohmann::json& j) { return j.is_null() ? std::numeric_limits<double>::quiet_NaN() : j.get<double>(); }

nlohmann::json roundedOrNull(const std::vector<double>& v) {
  nlohmann::json a = nlohmann::json::array();
  for (double x : v) a.push_back(std::isnan(x) ? nlohmann::json(nullptr) : nlohmann::json(rounded(x)));
  return a;
}

std::vector<double> numbersOrNaN(const nlohmann::json& a) {
  std::vector<double> v;
  for (const nlohmann::json& x : a) v.push_back(numberOrNaN(x));
  return v;
}

nlohmann::json boxJson(const analysis::Box& b) { return {{"lo", b.lo}, {"hi", b.hi}}; }
analysis::Box boxOf(const nlohmann::json& j) { return {j.at("lo").get<std::array<double, 3>>(), j.at("hi").get<std::array<double, 3>>()}; }

// The plot's part of a kept soil motion (SoilMotionEvaluation).
nlohmann::json soilMotionPlotJson(const SoilMotionEvaluation& m) {
  const analysis::SectionMap& v = m.vertical;
  nlohmann::json paths = nlohmann::json::array();
  for (const analysis::Streamline& l : m.streamline_paths) paths.push_back({{"u_m", roundedArray(l.u_m)}, {"v_m", roundedArray(l.v_m)}});
  return {{"vertical",
           {{"position_m", v.position_m}, {"half_thickness_m", v.half_thickness_m}, {"cell_m", v.cell_m}, {"u0_m", v.u0_m},
            {"v0_m", v.v0_m}, {"nu", v.nu}, {"nv", v.nv}, {"speed_m_s", roundedOrNull(v.values)}}},
          {"region", boxJson(m.region)},
          {"tool", boxJson(m.tool)},
          {"surface_y_m", m.surface_y_m},
          {"streamline_paths", paths}};
}

void readSoilMotionPlot(const nlohmann::json& j, SoilMotionEvaluation& m) {
  const nlohmann::json& v = j.at("vertical");
  m.vertical.axis = analysis::Axis::X;
  m.vertical.position_m = v.at("position_m"), m.vertical.half_thickness_m = v.at("half_thickness_m"), m.vertical.cell_m = v.at("cell_m");
  m.vertical.u0_m = v.at("u0_m"), m.vertical.v0_m = v.at("v0_m"), m.vertical.nu = v.at("nu"), m.vertical.nv = v.at("nv");
  m.vertical.values = numbersOrNaN(v.at("speed_m_s"));
  if (m.vertical.values.size() != static_cast<std::size_t>(m.vertical.nu) * static_cast<std::size_t>(m.vertical.nv))
    throw std::invalid_argument("/soil_motion/vertical/speed_m_s: not nu x nv values");
  m.region = boxOf(j.at("region")), m.tool = boxOf(j.at("tool")), m.surface_y_m = j.at("surface_y_m");
  for (const nlohmann::json& l : j.at("streamline_paths")) {
    analysis::Streamline line;
    line.u_m = l.at("u_m").get<std::vector<double>>();
    line.v_m = l.at("v_m").get<std::vector<double>>();
    if (line.u_m.size() != line.v_m.size()) throw std::invalid_argument("/soil_motion/streamline_paths: u_m and v_m of different lengths");
    m.streamline_paths.push_back(std::move(line));
  }
}

nlohmann::json soilMotionJson(const std::optional<SoilMotionEvaluation>& m) {
  if (!m) return nullptr;
  nlohmann::json j = soilMotionPlotJson(*m);
  j.update(nlohmann::json{{"displacement_mm", m->displacement_mm},     {"moving_depth_mm", m->moving_depth_mm},
          {"moving_length_mm", m->moving_length_mm},   {"moving_width_mm", m->moving_width_mm},
          {"moving_particles", m->moving_particles},   {"front_min_mm_s", m->front_min_mm_s},
          {"front_median_mm_s", m->front_median_mm_s}, {"front_max_mm_s", m->front_max_mm_s},
          {"front_particles", m->front_particles},     {"streamline_order", orNull(m->streamline_order)},
          {"mean_streamline_length_mm", orNull(m->mean_streamline_length_mm)}, {"streamlines", m->streamlines}});
  return j;
}

std::optional<SoilMotionEvaluation> soilMotionOf(const nlohmann::json& j) {
  if (j.is_null()) return std::nullopt;
  SoilMotionEvaluation m;
  m.displacement_mm = j.at("displacement_mm"), m.moving_depth_mm = j.at("moving_depth_mm");
  m.moving_length_mm = j.at("moving_length_mm"), m.moving_width_mm = j.at("moving_width_mm");
  m.moving_particles = j.at("moving_particles"), m.front_min_mm_s = j.at("front_min_mm_s");
  m.front_median_mm_s = j.at("front_median_mm_s"), m.front_max_mm_s = j.at("front_max_mm_s");
  m.front_particles = j.at("front_particles"), m.streamline_order = numberOrNaN(j.at("streamline_order"));
  m.mean_streamline_length_mm = numberOrNaN(j.at("mean_streamline_length_mm")), m.streamlines = j.at("streamlines");
  readSoilMotionPlot(j, m);
  return m;
}

nlohmann::json statisticsJson(const analysis::SignalStatistics& s) {
  return {{"mean", s.mean}, {"std_dev", s.std_dev}, {"samples", s.samples}};
}

analysis::SignalStatistics statisticsOf(const nlohmann::json& j) {
  return {j.at("mean").get<double>(), j.at("std_dev").get<double>(), j.at("samples").get<std::size_t>()};
}

// The kept evaluation of a case (see contract).
nlohmann::json keptJson(const ReportCase& c) {
  const Evaluated& e = *c.run;
  nlohmann::json window{{"force_N", statisticsJson(e.window.force_N)}, {"deformation_mm", statisticsJson(e.window.deformation_mm)}};
  window["tilt_deg"] = e.window.tilt_deg ? statisticsJson(*e.window.tilt_deg) : nlohmann::json(nullptr);
  return {{"case", c.name},
          {"study_fnv1a64", studyHash(c.study)},
          {"label", e.label},
          {"stroke_mm", e.stroke_mm},
          {"window_begin_mm", e.window_begin_mm},
          {"window_end_mm", e.window_end_mm},
          {"tilt_begin_mm", e.tilt_begin_mm},
          {"tilt_end_mm", e.tilt_end_mm},
          {"window", window},
          {"tilt_range_deg", e.tilt_range_deg ? nlohmann::json{e.tilt_range_deg->first, e.tilt_range_deg->second} : nlohmann::json(nullptr)},
          {"tilt_window_deg", e.tilt_window_deg ? statisticsJson(*e.tilt_window_deg) : nlohmann::json(nullptr)},
          {"fit_signal", e.fit_signal},
          {"fit",
           {{"a", e.fit.a}, {"b", e.fit.b}, {"log10_a_std_error", e.fit.log10_a_std_error}, {"b_std_error", e.fit.b_std_error},
            {"r_squared_log", e.fit.r_squared_log}, {"points", e.fit.points}, {"f_low_Hz", e.fit.f_low_Hz}, {"f_high_Hz", e.fit.f_high_Hz}}},
          {"spectrum",
           {{"frequency_Hz", roundedArray(e.spectrum.frequency_Hz)}, {"amplitude", roundedArray(e.spectrum.amplitude)},
            {"sample_rate_Hz", e.spectrum.sample_rate_Hz}, {"samples_used", e.spectrum.samples_used}}},
          {"curve",
           {{"time_s", roundedArray(e.curve.time_s)}, {"displacement_mm", roundedArray(e.curve.displacement_mm)},
            {"force_N", roundedArray(e.curve.force_N)}, {"deformation_mm", roundedArray(e.curve.deformation_mm)},
            {"tilt_deg", roundedArray(e.curve.tilt_deg)}}},
          {"soil_motion", soilMotionJson(e.soil_motion)},
          {"wall_time_s", e.wall_s},
          {"run_estimate_s", e.run_estimate_s}};
}

Evaluated evaluationOf(const nlohmann::json& j) {
  Evaluated e;
  e.kept = true;
  e.label = j.at("label").get<std::string>();
  e.stroke_mm = j.at("stroke_mm"), e.window_begin_mm = j.at("window_begin_mm"), e.window_end_mm = j.at("window_end_mm");
  e.tilt_begin_mm = j.at("tilt_begin_mm"), e.tilt_end_mm = j.at("tilt_end_mm");
  const nlohmann::json& w = j.at("window");
  e.window.force_N = statisticsOf(w.at("force_N"));
  e.window.deformation_mm = statisticsOf(w.at("deformation_mm"));
  if (!w.at("tilt_deg").is_null()) e.window.tilt_deg = statisticsOf(w.at("tilt_deg"));
  if (const nlohmann::json& t = j.at("tilt_range_deg"); !t.is_null()) e.tilt_range_deg = std::pair{t.at(0).get<double>(), t.at(1).get<double>()};
  if (const nlohmann::json& t = j.at("tilt_window_deg"); !t.is_null()) e.tilt_window_deg = statisticsOf(t);
  e.fit_signal = j.at("fit_signal").get<std::string>();
  const nlohmann::json& f = j.at("fit");
  e.fit.a = f.at("a"), e.fit.b = f.at("b"), e.fit.log10_a_std_error = f.at("log10_a_std_error"), e.fit.b_std_error = f.at("b_std_error");
  e.fit.r_squared_log = f.at("r_squared_log"), e.fit.points = f.at("points"), e.fit.f_low_Hz = f.at("f_low_Hz"), e.fit.f_high_Hz = f.at("f_high_Hz");
  const nlohmann::json& sp = j.at("spectrum");
  e.spectrum.frequency_Hz = sp.at("frequency_Hz").get<std::vector<double>>();
  e.spectrum.amplitude = sp.at("amplitude").get<std::vector<double>>();
  e.spectrum.sample_rate_Hz = sp.at("sample_rate_Hz"), e.spectrum.samples_used = sp.at("samples_used");
  const nlohmann::json& cv = j.at("curve");
  e.curve.time_s = cv.at("time_s").get<std::vector<double>>();
  e.curve.displacement_mm = cv.at("displacement_mm").get<std::vector<double>>();
  e.curve.force_N = cv.at("force_N").get<std::vector<double>>();
  e.curve.deformation_mm = cv.at("deformation_mm").get<std::vector<double>>();
  e.curve.tilt_deg = cv.at("tilt_deg").get<std::vector<double>>();
  const std::size_t n = e.curve.displacement_mm.size();
  if (e.curve.time_s.size() != n || e.curve.force_N.size() != n || e.curve.deformation_mm.size() != n ||
      (!e.curve.tilt_deg.empty() && e.curve.tilt_deg.size() != n) || e.spectrum.frequency_Hz.size() != e.spectrum.amplitude.size())
    throw std::invalid_argument("/curve or /spectrum: arrays of different lengths");
  if (j.contains("soil_motion")) e.soil_motion = soilMotionOf(j.at("soil_motion"));  // absent: kept before Fig. 16 was
  e.wall_s = j.at("wall_time_s"), e.run_estimate_s = j.at("run_estimate_s");
  return e;
}

// The kept evaluation of the case in `file`: nullopt without one, or when it is of another version
// of the case's study (then c.kept_stale). Throws analysis::InputError for a damaged file.
std::optional<Evaluated> readKept(const fs::path& file, ReportCase& c) {
  std::ifstream in(file);
  if (!in) return std::nullopt;
  try {
    const nlohmann::json j = nlohmann::json::parse(in);
    if (j.at("case").get<std::string>() != c.name) throw std::invalid_argument("/case is '" + j.at("case").get<std::string>() + "'");
    if (j.at("study_fnv1a64").get<std::string>() != studyHash(c.study)) {
      c.kept_stale = true;
      return std::nullopt;
    }
    return evaluationOf(j);
  } catch (const std::exception& x) {  // nlohmann's parse and type errors name the key or byte
    throw analysis::InputError(file.string() + ": not a kept evaluation of " + c.name + ": " + x.what());
  }
}

// A finished run of the case in the campaign directory, evaluated; nullopt when it has none.
std::optional<Evaluated> freshEvaluation(const ReportCase& c, const ReportOptions& o) {
  const fs::path run_dir = o.directory / c.name;
  if (!finishedRun(run_dir)) return std::nullopt;
  const study::Study run_study = study::loadStudy(run_dir / "study.json");
  if (!sameCase(run_study, c.study))
    throw ArgumentError(run_dir.string() + " holds a finished run of another study than the case " + c.name +
                        "; remove that directory to run the case again");
  Evaluated e;
  static_cast<RunEvaluation&>(e) = evaluateCampaignRun(run_dir, run_study);
  e.curve = thinned(e.curve);
  e.spectrum = binned(e.spectrum);
  e.run_estimate_s = o.estimate_wall_s(run_study);
  e.label = o.label;
  return e;
}

std::vector<ReportCase> collect(const std::vector<fs::path>& files, const ReportOptions& o, const fs::path& kept_dir) {
  std::vector<ReportCase> cases;
  for (const fs::path& file : files) {
    ReportCase c;
    c.name = file.stem().string();
    c.study = study::loadStudy(file);
    if (c.study.tools.empty() || (c.study.kind != study::StudyKind::Coupled && c.study.kind != study::StudyKind::DemOnly))
      throw ArgumentError(file.string() + ": the report's cases are coupled or dem-only soil-bin studies");
    c.paper = paperCaseOf(c.study);
    c.full_estimate_s = o.estimate_wall_s(c.study);
    c.run = freshEvaluation(c, o);
    if (!c.run) c.run = readKept(kept_dir / (c.name + ".json"), c);
    cases.push_back(std::move(c));
  }
  for (ReportCase& c : cases) {
    if (c.run) continue;
    double measured_s = 0, estimated_s = 0;
    for (const ReportCase& other : cases)
      if (other.run && other.run->run_estimate_s > 0 && other.study.kind == c.study.kind)
        measured_s += other.run->wall_s, estimated_s += other.run->run_estimate_s, ++c.cost_ratio_runs;
    if (c.cost_ratio_runs > 0) c.cost_ratio = measured_s / estimated_s;
  }
  return cases;
}

using namespace analysis::report;

using Case = const ReportCase*;

// A number of a finished run; absent for a case not finished.
CellValue ofRun(Case c, double Evaluated::*field) { return c->run ? std::optional<double>((*c->run).*field) : std::nullopt; }

// An end of an optional range: `first` the lower one.
CellValue rangeEnd(const std::optional<std::pair<double, double>>& range, bool first) {
  return range ? std::optional<double>(first ? range->first : range->second) : std::nullopt;
}

// The paper's tilt range of a case (Section 3), measured or simulated.
CellValue paperTilt(Case c, std::optional<std::pair<double, double>> PaperCase::*range, bool first) {
  return c->paper ? rangeEnd(c->paper->*range, first) : std::nullopt;
}

std::optional<std::pair<double, double>> runTilt(Case c) { return c->run ? c->run->tilt_range_deg : std::nullopt; }

// The full-scale wall time: the estimate scaled by measured / estimated of the run itself, or
// without one, of the finished runs of its model.
double projectedSeconds(Case c) {
  return c->run && c->run->run_estimate_s > 0 ? c->full_estimate_s * c->run->wall_s / c->run->run_estimate_s
                                              : c->full_estimate_s * c->cost_ratio;
}

// What projectedSeconds() scaled the estimate by, in words.
std::string projectionBasis(Case c) {
  if (c->run) return "measured cost";
  if (c->cost_ratio_runs == 0) return "estimate";
  return "estimate x " + formatted("%.2g", c->cost_ratio) + ", measured / estimated of " + std::to_string(c->cost_ratio_runs) +
         " finished " + kindName(c->study.kind) + (c->cost_ratio_runs == 1 ? " run" : " runs");
}

// Our mean tilt over the tilt window minus the midpoint of the paper's simulated range.
CellValue tiltAgainstPaper(Case c) {
  if (!c->run || !c->run->tilt_window_deg || !c->paper || !c->paper->simulated_tilt_deg) return std::nullopt;
  const auto& p = *c->paper->simulated_tilt_deg;
  return std::optional<double>(c->run->tilt_window_deg->mean - (p.first + p.second) / 2);
}

// A statistic of our tilt over the tilt window.
CellValue tiltStatistic(Case c, double analysis::SignalStatistics::*field) {
  return c->run && c->run->tilt_window_deg ? std::optional<double>((*c->run->tilt_window_deg).*field) : std::nullopt;
}

// "lo-hi" of two columns.
MarkdownCell rangeCell(const std::string& lo, const std::string& hi, const char* format = "%.2f") {
  return md::concat({md::format(lo, format), md::literal("-"), md::format(hi, format)});
}

// A measure of our soil motion (Fig. 16); absent without particle files.
CellValue ofMotion(Case c, double SoilMotionEvaluation::*field) {
  return c->run && c->run->soil_motion ? std::optional<double>((*c->run->soil_motion).*field) : std::nullopt;
}

CellValue motionCount(Case c, std::size_t SoilMotionEvaluation::*field) {
  if (!c->run || !c->run->soil_motion) return std::optional<double>();
  return static_cast<long long>((*c->run->soil_motion).*field);
}

// The paper's depth in motion or an end of its front speed range (Section 3.5).
CellValue paperMovingDepth(Case c) { return c->paper ? c->paper->moving_depth_mm : std::nullopt; }
CellValue paperFrontSpeed(Case c, bool first) { return c->paper ? rangeEnd(c->paper->front_speed_mm_s, first) : std::nullopt; }

CellValue movingDepthAgainstPaper(Case c) {
  if (!c->run || !c->run->soil_motion || !c->paper || !c->paper->moving_depth_mm) return std::nullopt;
  return std::optional<double>(c->run->soil_motion->moving_depth_mm - *c->paper->moving_depth_mm);
}

MarkdownCell ifFinished(MarkdownCell cell) { return md::onlyIf("finished", std::move(cell), ""); }

// A rigid tool (the paper's DEM-only cases) has no deformation to report.
bool deforms(Case c) { return c->study.tools.front().fem.deformable; }

// paper-reproduction.csv and the JSON's `cases`: one row per case, every table of the report a view of it.
const Section<Case>& caseSection() {
  using R = Case;
  static const Section<R> section{
      {{"name", [](R c) -> CellValue { return c->name; }},
       {"tool", [](R c) -> CellValue { return c->study.tools.front().name; }},
       {"model", [](R c) -> CellValue { return kindName(c->study.kind); }},
       {"depth_mm", [](R c) -> CellValue { return c->study.tools.front().motion.depth_m * 1e3; }},
       {"velocity_mm_s", [](R c) -> CellValue { return c->study.tools.front().motion.velocity_m_s * 1e3; }},
       {"paper_velocity_mm_s", [](R c) -> CellValue { return c->paper ? std::optional<double>(c->paper->velocity_mm_s) : std::nullopt; }},
       {"dem_step_s", [](R c) -> CellValue { return study::demStepDividing(physics::demTimeStep(c->study).step_s, c->study.fem.dt_s); }},
       {"critical_step_s", [](R c) -> CellValue { return physics::demTimeStep(c->study).critical_s; }},
       {"dem_step_why", [](R c) -> CellValue { return physics::demTimeStep(c->study).why; }},
       {"finished", [](R c) -> CellValue { return c->run.has_value(); }},
       {"kept", [](R c) -> CellValue { return c->run && c->run->kept; }},
       {"runs_label", [](R c) -> CellValue { return c->run ? c->run->label : std::string(); }},
       {"stroke_mm", [](R c) -> CellValue { return ofRun(c, &Evaluated::stroke_mm); }},
       {"window_begin_mm", [](R c) -> CellValue { return ofRun(c, &Evaluated::window_begin_mm); }},
       {"window_end_mm", [](R c) -> CellValue { return ofRun(c, &Evaluated::window_end_mm); }},
       {"force_mean_N", [](R c) -> CellValue { return c->run ? std::optional<double>(c->run->window.force_N.mean) : std::nullopt; }},
       {"force_std_N", [](R c) -> CellValue { return c->run ? std::optional<double>(c->run->window.force_N.std_dev) : std::nullopt; }},
       {"deforms", [](R c) -> CellValue { return deforms(c); }},
       {"deformation_mean_mm",
        [](R c) -> CellValue { return c->run && deforms(c) ? std::optional<double>(c->run->window.deformation_mm.mean) : std::nullopt; }},
       {"deformation_std_mm",
        [](R c) -> CellValue { return c->run && deforms(c) ? std::optional<double>(c->run->window.deformation_mm.std_dev) : std::nullopt; }},
       {"fit_signal", [](R c) -> CellValue { return c->run ? c->run->fit_signal : std::string(); }},
       {"fit_a", [](R c) -> CellValue { return c->run ? std::optional<double>(c->run->fit.a) : std::nullopt; }},
       {"fit_b", [](R c) -> CellValue { return c->run ? std::optional<double>(c->run->fit.b) : std::nullopt; }},
       {"fit_b_std_error", [](R c) -> CellValue { return c->run ? std::optional<double>(c->run->fit.b_std_error) : std::nullopt; }},
       {"paper_measured_tilt_min_deg", [](R c) { return paperTilt(c, &PaperCase::measured_tilt_deg, true); }},
       {"paper_measured_tilt_max_deg", [](R c) { return paperTilt(c, &PaperCase::measured_tilt_deg, false); }},
       {"paper_simulated_tilt_min_deg", [](R c) { return paperTilt(c, &PaperCase::simulated_tilt_deg, true); }},
       {"paper_simulated_tilt_max_deg", [](R c) { return paperTilt(c, &PaperCase::simulated_tilt_deg, false); }},
       {"tilt_begin_mm", [](R c) -> CellValue { return ofRun(c, &Evaluated::tilt_begin_mm); }},
       {"tilt_end_mm", [](R c) -> CellValue { return ofRun(c, &Evaluated::tilt_end_mm); }},
       {"tilt_min_deg", [](R c) { return rangeEnd(runTilt(c), true); }},
       {"tilt_max_deg", [](R c) { return rangeEnd(runTilt(c), false); }},
       {"tilt_mean_deg", [](R c) { return tiltStatistic(c, &analysis::SignalStatistics::mean); }},
       {"tilt_std_deg", [](R c) { return tiltStatistic(c, &analysis::SignalStatistics::std_dev); }},
       {"tilt_minus_paper_simulated_deg", [](R c) { return tiltAgainstPaper(c); }},
       {"paper_moving_depth_mm", [](R c) { return paperMovingDepth(c); }},
       {"paper_front_speed_min_mm_s", [](R c) { return paperFrontSpeed(c, true); }},
       {"paper_front_speed_max_mm_s", [](R c) { return paperFrontSpeed(c, false); }},
       {"soil_motion_at_mm", [](R c) { return ofMotion(c, &SoilMotionEvaluation::displacement_mm); }},
       {"moving_depth_mm", [](R c) { return ofMotion(c, &SoilMotionEvaluation::moving_depth_mm); }},
       {"moving_depth_minus_paper_mm", [](R c) { return movingDepthAgainstPaper(c); }},
       {"moving_length_mm", [](R c) { return ofMotion(c, &SoilMotionEvaluation::moving_length_mm); }},
       {"moving_width_mm", [](R c) { return ofMotion(c, &SoilMotionEvaluation::moving_width_mm); }},
       {"moving_particles", [](R c) { return motionCount(c, &SoilMotionEvaluation::moving_particles); }},
       {"front_speed_min_mm_s", [](R c) { return ofMotion(c, &SoilMotionEvaluation::front_min_mm_s); }},
       {"front_speed_median_mm_s", [](R c) { return ofMotion(c, &SoilMotionEvaluation::front_median_mm_s); }},
       {"front_speed_max_mm_s", [](R c) { return ofMotion(c, &SoilMotionEvaluation::front_max_mm_s); }},
       {"front_particles", [](R c) { return motionCount(c, &SoilMotionEvaluation::front_particles); }},
       {"streamline_order", [](R c) { return ofMotion(c, &SoilMotionEvaluation::streamline_order); }},
       {"streamlines", [](R c) { return motionCount(c, &SoilMotionEvaluation::streamlines); }},
       {"mean_streamline_length_mm", [](R c) { return ofMotion(c, &SoilMotionEvaluation::mean_streamline_length_mm); }},
       {"paper_hours", [](R c) -> CellValue { return c->paper ? std::optional<double>(c->paper->hours) : std::nullopt; }},
       {"wall_time_s", [](R c) -> CellValue { return ofRun(c, &Evaluated::wall_s); }},
       {"run_estimate_s", [](R c) -> CellValue { return ofRun(c, &Evaluated::run_estimate_s); }},
       {"full_scale_estimate_s", [](R c) -> CellValue { return c->full_estimate_s; }},
       {"projected_full_scale_h", [](R c) -> CellValue { return projectedSeconds(c) / 3600; }},
       {"projection", [](R c) -> CellValue { return projectionBasis(c); }},
       {"projected_over_paper",
        [](R c) -> CellValue { return c->paper ? std::optional<double>(projectedSeconds(c) / 3600 / c->paper->hours) : std::nullopt; }}},
      [](R c) { return c->name; },
      {{"tool", md::text("tool")},
       {"model", md::text("model")},
       {"depth mm", md::format("depth_mm", "%.0f")},
       {"velocity mm/s (paper)",
        md::concat({md::format("velocity_mm_s", "%.2f"), md::literal(" ("), md::format("paper_velocity_mm_s", "%.2f"), md::literal(")")})},
       {"run", md::onlyIf("finished", md::literal("finished"), "not finished")},
       {"stroke mm", ifFinished(md::format("stroke_mm", "%.0f"))},
       {"window mm", ifFinished(md::concat({md::format("window_begin_mm", "%.0f"), md::literal("-"), md::format("window_end_mm", "%.0f")}))},
       {"force N (mean ± sd)", ifFinished(md::concat({md::format("force_mean_N", "%.3g"), md::literal(" ± "), md::format("force_std_N", "%.2g")}))},
       {"deformation mm (mean ± sd)",
        md::onlyIf("deforms", ifFinished(md::concat({md::format("deformation_mean_mm", "%.3g"), md::literal(" ± "), md::format("deformation_std_mm", "%.2g")})),
                   "rigid tool")},
       {"FFT fit A = a f^b", ifFinished(md::concat({md::text("fit_signal"), md::literal(": a = "), md::format("fit_a", "%.3g"), md::literal(", b = "),
                                                   md::format("fit_b", "%.3f"), md::literal(" ± "), md::format("fit_b_std_error", "%.2f")}))}}};
  return section;
}

// The time step of each case (a view of caseSection()).
const std::vector<MarkdownColumn>& timeStepView() {
  static const std::vector<MarkdownColumn> view{{"DEM step s", md::format("dem_step_s", "%.3g")},
                                                {"critical step s", md::format("critical_step_s", "%.3g")},
                                                {"why", md::text("dem_step_why")}};
  return view;
}

// Section 3's tilt of the PMMA tool beside the paper's (a view of caseSection()).
const std::vector<MarkdownColumn>& tiltView() {
  static const std::vector<MarkdownColumn> view{
      {"paper measured deg", md::ifDefined("paper_measured_tilt_min_deg", rangeCell("paper_measured_tilt_min_deg", "paper_measured_tilt_max_deg"), "-")},
      {"paper simulated deg", rangeCell("paper_simulated_tilt_min_deg", "paper_simulated_tilt_max_deg")},
      {"ours deg (tilt window)",
       md::ifDefined("tilt_min_deg",
                     md::concat({rangeCell("tilt_min_deg", "tilt_max_deg"), md::literal(" ("), md::format("tilt_begin_mm", "%.0f"), md::literal("-"),
                                 md::format("tilt_end_mm", "%.0f"), md::literal(" mm)")}),
                     "not finished")},
      {"ours mean ± sd deg", md::ifDefined("tilt_mean_deg", md::concat({md::format("tilt_mean_deg", "%.2f"), md::literal(" ± "), md::format("tilt_std_deg", "%.2f")}), "")},
      {"ours mean - paper simulated midpoint deg", md::ifDefined("tilt_minus_paper_simulated_deg", md::format("tilt_minus_paper_simulated_deg", "%+.2f"), "")}};
  return view;
}

// Section 3.5's soil motion beside Fig. 16's (a view of caseSection()).
const std::vector<MarkdownColumn>& soilMotionView() {
  static const std::vector<MarkdownColumn> view{
      {"model", md::text("model")},
      {"paper: depth in motion mm", md::format("paper_moving_depth_mm", "%.0f")},
      {"ours mm (at displacement)",
       md::ifDefined("moving_depth_mm",
                     md::concat({md::format("moving_depth_mm", "%.0f"), md::literal(" (at "), md::format("soil_motion_at_mm", "%.0f"), md::literal(" mm)")}),
                     "no particle files")},
      {"ours - paper mm", md::ifDefined("moving_depth_minus_paper_mm", md::format("moving_depth_minus_paper_mm", "%+.0f"), "")},
      {"paper: in front of the tool mm/s", rangeCell("paper_front_speed_min_mm_s", "paper_front_speed_max_mm_s", "%.0f")},
      {"ours mm/s (median; particles)",
       md::ifDefined("front_speed_min_mm_s",
                     md::concat({rangeCell("front_speed_min_mm_s", "front_speed_max_mm_s", "%.0f"), md::literal(" ("),
                                 md::format("front_speed_median_mm_s", "%.0f"), md::literal("; "), md::format("front_particles", "%.0f"), md::literal(")")}),
                     "")},
      {"ours: region in motion, length x width mm",
       md::ifDefined("moving_length_mm", md::concat({md::format("moving_length_mm", "%.0f"), md::literal(" x "), md::format("moving_width_mm", "%.0f")}), "")},
      {"ours: streamline order (mean length mm)",
       md::ifDefined("moving_length_mm",
                     md::concat({md::format("streamline_order", "%.2f"), md::literal(" ("), md::format("mean_streamline_length_mm", "%.0f"), md::literal(")")}),
                     "")}};
  return view;
}

// Computing time beside Table 1 (a view of caseSection()).
const std::vector<MarkdownColumn>& hoursView() {
  static const std::vector<MarkdownColumn> view{
      {"paper h (8-core i7-9700)", md::format("paper_hours", "%.0f")},
      {"ours: run wall time",
       md::onlyIf("finished", md::concat({md::format("wall_time_s", "%.0f s"), md::literal(" ("), md::format("stroke_mm", "%.0f"), md::literal(" mm stroke)")}),
                  "not finished")},
      {"ours: full scale, projected h",
       md::concat({md::format("projected_full_scale_h", "%.2g"), md::literal(" ("), md::text("projection"), md::literal(")")})},
      {"ours / paper", md::format("projected_over_paper", "%.2g")},
      {"runs", md::onlyIf("finished", md::concat({md::onlyIf("kept", md::literal("kept: "), "this report: "), md::text("runs_label")}), "")}};
  return view;
}

// How the soil-motion table's numbers are measured, from the settings they are measured with.
std::string soilMotionIntroduction() {
  const analysis::SoilMotionSettings s;
  return "From the particle files of runs with `output.vtk_every` > 0, by `demfem soil-motion`'s measures and defaults, at the "
         "frame nearest to the displacement: in motion is faster than " + formatted("%g", s.threshold_m_s * 1e3) +
         " mm/s (the paper does not state its threshold); the region in motion is the fast particles connected to the tool "
         "(linked across gaps up to " + formatted("%g", s.connect_gap_m * 1e3) + " mm), its depth the lowest point of that region below the "
         "surface; the speeds are those of the particles directly in front of the tool (across its width, from its tip to the "
         "surface, " + formatted("%g", s.front_reach_m * 1e3) + " mm ahead of its front face); the streamline order is the "
         "alignment of the moving particles' directions on the vertical section through the tool (1: all parallel).\n\n";
}

// The cases the paper describes the soil motion of (Fig. 16).
std::vector<Case> soilMotionRows(const std::vector<ReportCase>& cases) {
  std::vector<Case> rows;
  for (const ReportCase& c : cases)
    if (c.paper && c.paper->moving_depth_mm) rows.push_back(&c);
  return rows;
}

std::vector<Case> caseRows(const std::vector<ReportCase>& cases) {
  std::vector<Case> rows;
  for (const ReportCase& c : cases) rows.push_back(&c);
  return rows;
}

// The cases the paper gives a simulated tilt for.
std::vector<Case> tiltRows(const std::vector<ReportCase>& cases) {
  std::vector<Case> rows;
  for (const ReportCase& c : cases)
    if (c.paper && c.paper->simulated_tilt_deg) rows.push_back(&c);
  return rows;
}

// Why the cases step as they do, the step of each, and the convergence study behind it.
std::string timeStepSection(const std::vector<ReportCase>& cases, const std::vector<ConvergenceSummary>& convergence) {
  std::ostringstream md;
  md << "The paper steps its DEM at 7.93e-7 s, 20 % of a Rayleigh estimate made with the shear modulus G = 4.3e10 Pa. Its "
        "contact law does not use G: the hysteretic spring loads at K1 = 5 R* Y with the yield strength Y = 5.88e5 Pa and unloads "
        "at K2 = K1 / e^2, so a particle contact lasts about a millisecond. The cases here step at `dem.dt_fraction` of the "
        "stiffest spring's contact half period pi sqrt(m*/k_max) over the particle, bin and tool contacts (docs/architecture.md "
        "section 11); `dem.dt_s` = 7.93e-7 keeps the paper's step.\n\n"
     << caseSection().markdownOf(caseRows(cases), timeStepView()) << '\n';
  for (const ConvergenceSummary& study : convergence)
    md << "Convergence (`demfem-bench-paper-convergence`):\n\n" << markdown(study) << '\n';
  return md.str();
}

analysis::Series series(const std::string& title, std::vector<double> x, std::vector<double> y, const char* color) {
  return analysis::Series{title, std::move(x), std::move(y), color, analysis::SeriesStyle::Line, 1.2};
}

const char* caseColor(std::size_t i) {
  static const char* colors[] = {analysis::kSimulatedColor, analysis::kMeasuredColor, "#70ad47", "#ffc000", "#4472c4", "#ff0000"};
  return colors[i % std::size(colors)];
}

// One panel per (tool, model): the finished cases' curves of `signal` against displacement.
analysis::Figure curvesFigure(const std::vector<ReportCase>& cases, bool force) {
  analysis::Figure f;
  f.title = force ? "Force against tool displacement (cf. Figs. 9 and 14 b)" : "Deformation against tool displacement (cf. Fig. 14 a)";
  std::map<std::string, analysis::XYPanel> panels;
  for (const ReportCase& c : cases) {
    if (!c.run || (!force && c.study.kind == study::StudyKind::DemOnly)) continue;
    const std::string group = c.study.tools.front().name + " " + kindName(c.study.kind);
    analysis::XYPanel& p = panels[group];
    p.title = group;
    p.x_label = "tool displacement (mm)";
    p.y_label = force ? "force (N)" : "deformation (mm)";
    p.series.push_back(series(c.name, c.run->curve.displacement_mm, force ? c.run->curve.force_N : c.run->curve.deformation_mm,
                              caseColor(p.series.size())));
  }
  for (auto& [name, p] : panels) f.panels.push_back(p);
  f.columns = 1;
  return f;
}

analysis::Figure spectraFigure(const std::vector<ReportCase>& cases) {
  analysis::Figure f;
  f.title = "Amplitude spectra over the window and power-law fits (cf. Fig. 17)";
  for (const ReportCase& c : cases) {
    if (!c.run) continue;
    analysis::XYPanel p;
    p.title = c.name + " (" + c.run->fit_signal + ")";
    p.x_label = "frequency (Hz)";
    p.y_label = c.run->fit_signal == "force" ? "amplitude (N)" : "amplitude (mm)";
    p.log_x = p.log_y = true;
    p.key_position = "bottom left";
    std::vector<double> fx, ax, fitted;
    for (std::size_t i = 0; i < c.run->spectrum.frequency_Hz.size(); ++i)
      if (c.run->spectrum.amplitude[i] > 0 && c.run->spectrum.frequency_Hz[i] >= kFitLowHz) {
        fx.push_back(c.run->spectrum.frequency_Hz[i]);
        ax.push_back(c.run->spectrum.amplitude[i]);
        fitted.push_back(c.run->fit.evaluate(fx.back()));
      }
    p.series.push_back(series("FFT", fx, ax, analysis::kSimulatedColor));
    p.series.push_back(analysis::Series{"a f^b", fx, fitted, analysis::kMeasuredColor, analysis::SeriesStyle::DashedLine, 1.5});
    f.panels.push_back(p);
  }
  f.columns = 2;
  return f;
}

// The vertical velocity sections of the cases with soil motion, as `demfem soil-motion` draws them,
// from the kept form (the same figure from the runs and from kept evaluations).
analysis::Figure soilMotionFigure(const std::vector<ReportCase>& cases) {
  std::vector<analysis::SoilMotionRun> runs;
  for (const ReportCase& c : cases) {
    if (!c.run || !c.run->soil_motion) continue;
    const SoilMotionEvaluation& m = *c.run->soil_motion;
    analysis::SoilMotionRun r;
    r.name = c.name;
    r.surface_y_m = m.surface_y_m;
    analysis::SoilMotionInstant in;
    in.displacement_m = m.displacement_mm * 1e-3;
    in.vertical = m.vertical;
    in.tool = m.tool;
    in.extent.count = m.moving_particles;
    in.extent.region = m.region;
    in.streamlines = m.streamline_paths;
    r.instants.push_back(std::move(in));
    runs.push_back(std::move(r));
  }
  if (runs.empty()) return {};
  analysis::Figure f = analysis::sectionsFigure(runs, true);
  f.columns = 1;  // the bin is 650 x 85 mm: one wide panel per case
  f.width_px = 1400;
  f.row_height_px = 330;
  return f;
}

// Renders `figure` to plots/NAME.svg (script beside it); the Markdown image line.
std::string plotFile(analysis::StagedOutput& out, const analysis::GnuplotRenderer& renderer, const std::string& name,
                     const analysis::Figure& figure) {
  if (figure.panels.empty()) return {};
  const std::string svg = "plots/" + name + ".svg";
  renderer.render(figure, out.stage("plots/" + name + ".gp"), out.stage(svg));
  return "![" + figure.title + "](" + svg + ")\n\n";
}

}  // namespace

const std::vector<PaperCase>& paperCases() {
  using K = study::StudyKind;
  // Table 1 (velocity, measurement time, hours); Section 3 text (tilt at 200-400 mm, PMMA); Section 3.5
  // text (Fig. 16 at 300 mm, 42 mm deep: depth in motion, speeds directly in front of the tool).
  static const std::vector<PaperCase> cases{
      {"S235", K::DemOnly, 18, 31.19, 19.24, 44, std::nullopt, std::nullopt, std::nullopt, std::nullopt},
      {"S235", K::DemOnly, 30, 30.03, 19.98, 46, std::nullopt, std::nullopt, std::nullopt, std::nullopt},
      {"S235", K::DemOnly, 42, 32.22, 18.62, 43, std::nullopt, std::nullopt, 58.0, std::pair{23.0, 28.0}},
      {"S235", K::Coupled, 18, 31.19, 19.24, 28, std::nullopt, std::nullopt, std::nullopt, std::nullopt},
      {"S235", K::Coupled, 30, 30.03, 19.98, 52, std::nullopt, std::nullopt, std::nullopt, std::nullopt},
      {"S235", K::Coupled, 42, 32.22, 18.62, 96, std::nullopt, std::nullopt, 55.0, std::pair{23.0, 40.0}},
      {"PMMA", K::Coupled, 18, 36.14, 16.60, 46, std::pair{0.2, 0.3}, std::pair{0.7, 0.9}, std::nullopt, std::nullopt},
      {"PMMA", K::Coupled, 30, 28.76, 20.86, 54, std::pair{2.0, 2.1}, std::pair{2.1, 2.3}, std::nullopt, std::nullopt},
      {"PMMA", K::Coupled, 42, 34.09, 17.60, 42, std::pair{5.3, 6.5}, std::pair{5.6, 8.7}, 83.0, std::pair{40.0, 100.0}}};
  return cases;
}

const PaperCase* paperCaseOf(const study::Study& s) {
  if (s.tools.empty()) return nullptr;
  for (const PaperCase& p : paperCases())
    if (p.tool == s.tools.front().name && p.kind == s.kind && std::fabs(p.depth_mm - s.tools.front().motion.depth_m * 1e3) < 0.5) return &p;
  return nullptr;
}

RunEvaluation evaluatePaperRun(const analysis::Recording& rec, const study::Study& run_study) {
  RunEvaluation e;
  e.stroke_mm = run_study.tools.front().motion.stroke_m * 1e3;
  const double scale = std::min(1.0, e.stroke_mm / kPaperStrokeMm);
  e.window_begin_mm = kWindowBeginMm * scale;
  e.window_end_mm = kWindowEndMm * scale;
  e.tilt_begin_mm = kTiltBeginMm * scale;
  e.tilt_end_mm = kTiltEndMm * scale;
  analysis::EvaluationSettings settings;
  settings.window_begin_mm = e.window_begin_mm;
  settings.window_end_mm = e.window_end_mm;
  const analysis::EvaluatedRun run = analysis::evaluateSoilBinRun(rec, settings);
  e.window = run.window;
  e.curve = run.curve;
  if (!run.curve.tilt_deg.empty()) {
    e.tilt_range_deg = rangeIn(run.curve.displacement_mm, run.curve.tilt_deg, e.tilt_begin_mm, e.tilt_end_mm);
    e.tilt_window_deg = analysis::windowStatistics(run.curve.displacement_mm, run.curve.tilt_deg, e.tilt_begin_mm, e.tilt_end_mm);
  }
  std::vector<double> t, signal;
  const bool rigid = run.window.deformation_mm.std_dev == 0;
  e.fit_signal = rigid ? "force" : "deformation";
  for (std::size_t i = 0; i < run.curve.size(); ++i) {
    const double x = run.curve.displacement_mm[i];
    if (x < e.window_begin_mm || x > e.window_end_mm) continue;
    t.push_back(run.curve.time_s[i]);
    signal.push_back(rigid ? run.curve.force_N[i] : run.curve.deformation_mm[i]);
  }
  e.spectrum = analysis::amplitudeSpectrum(t, signal);
  e.fit = analysis::fitPowerLaw(e.spectrum.frequency_Hz, e.spectrum.amplitude, kFitLowHz, e.spectrum.sample_rate_Hz / 2);
  return e;
}

namespace {

// Fig. 16's measures of a run with particle files at kSoilMotionAtMm scaled by stroke / 600 mm.
SoilMotionEvaluation soilMotionAt(const fs::path& run_dir, double stroke_mm) {
  analysis::SoilMotionSettings settings;
  settings.displacements_m = {kSoilMotionAtMm * std::min(1.0, stroke_mm / kPaperStrokeMm) * 1e-3};
  const analysis::SoilMotionRun run = analysis::analyseRun(run_dir, settings);
  const analysis::SoilMotionInstant& in = run.instants.at(0);
  SoilMotionEvaluation m;
  m.displacement_mm = in.displacement_m * 1e3;
  m.moving_depth_mm = in.extent.depth_m * 1e3, m.moving_length_mm = in.extent.length_m * 1e3, m.moving_width_mm = in.extent.width_m * 1e3;
  m.moving_particles = in.extent.count;
  m.front_min_mm_s = in.front.min_m_s * 1e3, m.front_median_mm_s = in.front.median_m_s * 1e3, m.front_max_mm_s = in.front.max_m_s * 1e3;
  m.front_particles = in.front.count;
  m.streamline_order = in.order.order;
  m.mean_streamline_length_mm = in.streamline_statistics.mean_length_m * 1e3;
  m.streamlines = in.streamline_statistics.count;
  m.vertical = in.vertical;
  m.region = in.extent.region, m.tool = in.tool, m.surface_y_m = run.surface_y_m;
  m.streamline_paths = in.streamlines;
  return m;
}

}  // namespace

RunEvaluation evaluateCampaignRun(const fs::path& run_dir, const study::Study& run_study) {
  RunEvaluation e = evaluatePaperRun(analysis::readRecording(run_dir / "sensors.csv"), run_study);
  if (fs::exists(run_dir / "vtk" / "particles.pvd")) e.soil_motion = soilMotionAt(run_dir, e.stroke_mm);
  std::ifstream record(run_dir / kRunRecord);
  if (!record) throw analysis::InputError((run_dir / kRunRecord).string() + ": missing (the run's wall time)");
  try {
    e.wall_s = nlohmann::json::parse(record).at("wall_time_s").get<double>();
  } catch (const nlohmann::json::exception& x) {
    throw analysis::InputError((run_dir / kRunRecord).string() + ": " + x.what());
  }
  return e;
}

nlohmann::json writePaperReport(const std::vector<fs::path>& study_files, const ReportOptions& o, analysis::StagedOutput& out) {
  if (!o.estimate_wall_s) throw ArgumentError("report: no cost estimate given");
  const std::vector<ReportCase> cases = collect(study_files, o, out.directory() / kKeptDirectory);
  std::string stale;
  for (const ReportCase& c : cases) {
    if (c.kept_stale) stale += (stale.empty() ? "" : ", ") + c.name;
    if (c.run) out.writeText(std::string(kKeptDirectory) + "/" + c.name + ".json", keptJson(c).dump(1) + '\n');
  }
  std::ostringstream md;
  md << "# The paper at its own scale: reproduction report\n\n"
     << "Generated by `demfem campaign --report` from the campaign runs in `" << o.directory.filename().string() << "`"
     << (o.label.empty() ? std::string() : " (" + o.label + ")")
     << " and, for a case without a finished run there, the evaluation an earlier report kept in `" << kKeptDirectory
     << "/` (the last table's column `runs` says which, with the label of its runs); do not edit by hand. How the cases are "
        "run, resumed and evaluated: `demfem campaign --help` and `campaign/include/demfem/campaign/paper_report.hpp`.\n\n"
     << (stale.empty() ? std::string()
                       : "Not used: the kept evaluations of " + stale + ", made of another version of their study.\n\n")
     << "A finished run shorter than the paper's 600 mm stroke is evaluated over the same fractions of its stroke "
        "(100-500 mm and 200-400 mm scaled by stroke / 600 mm). The paper states Fig. 15's means and Fig. 17's fits as "
        "figures only; the tables give ours.\n\n"
     << "## Time step\n\n" << timeStepSection(cases, o.convergence)
     << "## Cases (Table 1), Fig. 15 means and Fig. 17 fits\n\n" << caseSection().markdownOf(caseRows(cases))
     << "\n## Tilt of the PMMA tool at 200-400 mm (Section 3)\n\n" << caseSection().markdownOf(tiltRows(cases), tiltView())
     << "\n## Soil motion at " << formatted("%.0f", kSoilMotionAtMm) << " mm, 42 mm deep (Section 3.5, Fig. 16)\n\n" << soilMotionIntroduction()
     << caseSection().markdownOf(soilMotionRows(cases), soilMotionView())
     << "\n## Computing time beside Table 1\n\nOurs: the built-in DEM on this machine; the projection scales the "
        "full-scale estimate (`demfem validate`) by the measured / estimated cost of the run itself, and that of a case "
        "not run by the measured / estimated cost of the finished runs of its model (DEM-FEM or DEM).\n\n"
     << caseSection().markdownOf(caseRows(cases), hoursView()) << '\n';
  if (o.renderer) {
    md << "## Figures\n\n"
       << plotFile(out, *o.renderer, "paper_force_curves", curvesFigure(cases, true))
       << plotFile(out, *o.renderer, "paper_deformation_curves", curvesFigure(cases, false))
       << plotFile(out, *o.renderer, "paper_spectra", spectraFigure(cases))
       << plotFile(out, *o.renderer, "paper_soil_motion", soilMotionFigure(cases));
  }
  out.writeText("paper-reproduction.md", md.str());
  out.writeText("paper-reproduction.csv", caseSection().csv(caseRows(cases)));
  return {{"cases", caseSection().json(caseRows(cases))}};
}

}  // namespace demfem::campaign

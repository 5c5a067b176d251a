// docs/paper-reproduction.md from campaign runs, beside the paper's stated numbers
// (campaign/paper_report.hpp).
#include "demfem/campaign/paper_report.hpp"

#include "demfem/analysis/evaluation.hpp"
#include "demfem/analysis/recording.hpp"
#include "demfem/analysis/spectrum.hpp"
#include "demfem/backends/physics/time_step.hpp"
#include "demfem/study/tool_motion.hpp"
#include "demfem/campaign/paper_campaign.hpp"
#include "demfem/campaign/parameters.hpp"

#include "paper_format.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
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

struct Evaluated : RunEvaluation {
  double run_estimate_s = 0;
};

struct ReportCase {
  std::string name;
  study::Study study;
  const PaperCase* paper = nullptr;
  double full_estimate_s = 0;
  std::optional<Evaluated> run;
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

std::vector<ReportCase> collect(const std::vector<fs::path>& files, const ReportOptions& o) {
  std::vector<ReportCase> cases;
  for (const fs::path& file : files) {
    ReportCase c;
    c.name = file.stem().string();
    c.study = study::loadStudy(file);
    if (c.study.tools.empty() || (c.study.kind != study::StudyKind::Coupled && c.study.kind != study::StudyKind::DemOnly))
      throw ArgumentError(file.string() + ": the report's cases are coupled or dem-only soil-bin studies");
    c.paper = paperCaseOf(c.study);
    c.full_estimate_s = o.estimate_wall_s(c.study);
    const fs::path run_dir = o.directory / c.name;
    if (finishedRun(run_dir)) {
      const study::Study run_study = study::loadStudy(run_dir / "study.json");
      Evaluated e;
      static_cast<RunEvaluation&>(e) = evaluateCampaignRun(run_dir, run_study);
      e.run_estimate_s = o.estimate_wall_s(run_study);
      c.run = e;
    }
    cases.push_back(std::move(c));
  }
  return cases;
}

std::string range(const std::pair<double, double>& r) { return formatNumber("%.2f", r.first) + "-" + formatNumber("%.2f", r.second); }

std::string caseTable(const std::vector<ReportCase>& cases) {
  std::ostringstream md;
  md << "| case | tool | model | depth mm | velocity mm/s (paper) | run | stroke mm | window mm | force N (mean ± sd) | "
        "deformation mm (mean ± sd) | FFT fit A = a f^b |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const ReportCase& c : cases) {
    const auto& m = c.study.tools.front().motion;
    md << "| " << c.name << " | " << c.study.tools.front().name << " | " << kindName(c.study.kind) << " | " << formatNumber("%.0f", m.depth_m * 1e3)
       << " | " << formatNumber("%.2f", m.velocity_m_s * 1e3) << " (" << (c.paper ? formatNumber("%.2f", c.paper->velocity_mm_s) : "-") << ") | ";
    if (!c.run) {
      md << "not finished | | | | | |\n";
      continue;
    }
    const Evaluated& e = *c.run;
    md << "finished | " << formatNumber("%.0f", e.stroke_mm) << " | " << formatNumber("%.0f", e.window_begin_mm) << "-" << formatNumber("%.0f", e.window_end_mm) << " | "
       << formatNumber("%.3g", e.window.force_N.mean) << " ± " << formatNumber("%.2g", e.window.force_N.std_dev) << " | "
       << formatNumber("%.3g", e.window.deformation_mm.mean) << " ± " << formatNumber("%.2g", e.window.deformation_mm.std_dev) << " | " << e.fit_signal
       << ": a = " << formatNumber("%.3g", e.fit.a) << ", b = " << formatNumber("%.3f", e.fit.b) << " ± " << formatNumber("%.2f", e.fit.b_std_error) << " |\n";
  }
  return md.str();
}

std::string tiltTable(const std::vector<ReportCase>& cases) {
  std::ostringstream md;
  md << "| case | paper measured deg | paper simulated deg | ours deg (tilt window) | ours - paper simulated (midpoints) deg |\n"
        "|---|---|---|---|---|\n";
  for (const ReportCase& c : cases) {
    if (!c.paper || !c.paper->simulated_tilt_deg) continue;
    const auto& p = *c.paper->simulated_tilt_deg;
    md << "| " << c.name << " | " << (c.paper->measured_tilt_deg ? range(*c.paper->measured_tilt_deg) : "-") << " | " << range(p) << " | ";
    if (c.run && c.run->tilt_range_deg) {
      const auto& o = *c.run->tilt_range_deg;
      md << range(o) << " (" << formatNumber("%.0f", c.run->tilt_begin_mm) << "-" << formatNumber("%.0f", c.run->tilt_end_mm) << " mm) | "
         << formatNumber("%+.2f", (o.first + o.second) / 2 - (p.first + p.second) / 2) << " |\n";
    } else {
      md << "not finished | |\n";
    }
  }
  return md.str();
}

std::string hoursTable(const std::vector<ReportCase>& cases) {
  std::ostringstream md;
  md << "| case | paper h (8-core i7-9700) | ours: run wall time | ours: full scale, projected h | ours / paper |\n|---|---|---|---|---|\n";
  for (const ReportCase& c : cases) {
    const double projected_s = c.run && c.run->run_estimate_s > 0 ? c.full_estimate_s * c.run->wall_s / c.run->run_estimate_s : c.full_estimate_s;
    md << "| " << c.name << " | " << (c.paper ? formatNumber("%.0f", c.paper->hours) : "-") << " | "
       << (c.run ? formatNumber("%.0f s", c.run->wall_s) + " (" + formatNumber("%.0f", c.run->stroke_mm) + " mm stroke)" : std::string("not finished")) << " | "
       << formatNumber("%.1f", projected_s / 3600) << (c.run ? " (measured cost)" : " (estimate)") << " | "
       << (c.paper ? formatNumber("%.2f", projected_s / 3600 / c.paper->hours) : "-") << " |\n";
  }
  return md.str();
}

// Why the cases step as they do, the step of each, and the convergence study behind it.
std::string timeStepSection(const std::vector<ReportCase>& cases, const std::optional<ConvergenceSummary>& convergence) {
  std::ostringstream md;
  md << "The paper steps its DEM at 7.93e-7 s, 20 % of a Rayleigh estimate made with the shear modulus G = 4.3e10 Pa. Its "
        "contact law does not use G: the hysteretic spring loads at K1 = 5 R* Y with the yield strength Y = 5.88e5 Pa and unloads "
        "at K2 = K1 / e^2, so a particle contact lasts about a millisecond. The cases here step at `dem.dt_fraction` of the "
        "stiffest spring's contact half period pi sqrt(m*/k_max) over the particle, bin and tool contacts (docs/architecture.md "
        "section 11); `dem.dt_s` = 7.93e-7 keeps the paper's step.\n\n| case | DEM step s | critical step s | why |\n|---|---|---|---|\n";
  for (const ReportCase& c : cases) {
    const physics::DemStep step = physics::demTimeStep(c.study);
    md << "| " << c.name << " | " << formatNumber("%.3g", study::demStepDividing(step.step_s, c.study.fem.dt_s)) << " | "
       << formatNumber("%.3g", step.critical_s) << " | " << step.why << " |\n";
  }
  md << '\n';
  if (convergence) md << "Convergence (`demfem-bench-paper-convergence`):\n\n" << markdown(*convergence) << '\n';
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

// Renders `figure` to plots/NAME.svg (script beside it); the Markdown image line.
std::string plotFile(analysis::StagedOutput& out, const analysis::GnuplotRenderer& renderer, const std::string& name,
                     const analysis::Figure& figure) {
  if (figure.panels.empty()) return {};
  const std::string svg = "plots/" + name + ".svg";
  renderer.render(figure, out.stage("plots/" + name + ".gp"), out.stage(svg));
  return "![" + figure.title + "](" + svg + ")\n\n";
}

nlohmann::json caseJson(const ReportCase& c) {
  nlohmann::json j{{"name", c.name}, {"tool", c.study.tools.front().name}, {"model", kindName(c.study.kind)},
                   {"depth_mm", c.study.tools.front().motion.depth_m * 1e3}, {"full_scale_estimate_s", c.full_estimate_s},
                   {"paper_hours", c.paper ? nlohmann::json(c.paper->hours) : nlohmann::json(nullptr)}, {"finished", c.run.has_value()}};
  if (!c.run) return j;
  const Evaluated& e = *c.run;
  j["stroke_mm"] = e.stroke_mm;
  j["window_mm"] = {e.window_begin_mm, e.window_end_mm};
  j["force_mean_N"] = e.window.force_N.mean;
  j["force_std_N"] = e.window.force_N.std_dev;
  j["deformation_mean_mm"] = e.window.deformation_mm.mean;
  j["deformation_std_mm"] = e.window.deformation_mm.std_dev;
  j["fit"] = {{"signal", e.fit_signal}, {"a", e.fit.a}, {"b", e.fit.b}, {"b_std_error", e.fit.b_std_error}};
  if (e.tilt_range_deg) j["tilt_range_deg"] = {e.tilt_range_deg->first, e.tilt_range_deg->second};
  j["wall_time_s"] = e.wall_s;
  j["run_estimate_s"] = e.run_estimate_s;
  return j;
}

}  // namespace

const std::vector<PaperCase>& paperCases() {
  using K = study::StudyKind;
  // Table 1 (velocity, measurement time, hours); Section 3 text (tilt at 200-400 mm, PMMA).
  static const std::vector<PaperCase> cases{
      {"S235", K::DemOnly, 18, 31.19, 19.24, 44, std::nullopt, std::nullopt},
      {"S235", K::DemOnly, 30, 30.03, 19.98, 46, std::nullopt, std::nullopt},
      {"S235", K::DemOnly, 42, 32.22, 18.62, 43, std::nullopt, std::nullopt},
      {"S235", K::Coupled, 18, 31.19, 19.24, 28, std::nullopt, std::nullopt},
      {"S235", K::Coupled, 30, 30.03, 19.98, 52, std::nullopt, std::nullopt},
      {"S235", K::Coupled, 42, 32.22, 18.62, 96, std::nullopt, std::nullopt},
      {"PMMA", K::Coupled, 18, 36.14, 16.60, 46, std::pair{0.2, 0.3}, std::pair{0.7, 0.9}},
      {"PMMA", K::Coupled, 30, 28.76, 20.86, 54, std::pair{2.0, 2.1}, std::pair{2.1, 2.3}},
      {"PMMA", K::Coupled, 42, 34.09, 17.60, 42, std::pair{5.3, 6.5}, std::pair{5.6, 8.7}}};
  return cases;
}

const PaperCase* paperCaseOf(const study::Study& s) {
  if (s.tools.empty()) return nullptr;
  for (const PaperCase& p : paperCases())
    if (p.tool == s.tools.front().name && p.kind == s.kind && std::fabs(p.depth_mm - s.tools.front().motion.depth_m * 1e3) < 0.5) return &p;
  return nullptr;
}

RunEvaluation evaluateCampaignRun(const fs::path& run_dir, const study::Study& run_study) {
  RunEvaluation e;
  const analysis::Recording rec = analysis::readRecording(run_dir / "sensors.csv");
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
  if (!run.curve.tilt_deg.empty())
    e.tilt_range_deg = rangeIn(run.curve.displacement_mm, run.curve.tilt_deg, e.tilt_begin_mm, e.tilt_end_mm);
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
  const std::vector<ReportCase> cases = collect(study_files, o);
  std::ostringstream md;
  md << "# The paper at its own scale: reproduction report\n\n"
     << "Generated by `demfem campaign --report` from the campaign runs in `" << o.directory.filename().string() << "`"
     << (o.label.empty() ? std::string() : " (" + o.label + ")")
     << "; do not edit by hand. How the cases are run, resumed and evaluated: `demfem campaign --help` and "
        "`campaign/include/demfem/campaign/paper_report.hpp`.\n\n"
     << "A finished run shorter than the paper's 600 mm stroke is evaluated over the same fractions of its stroke "
        "(100-500 mm and 200-400 mm scaled by stroke / 600 mm). The paper states Fig. 15's means and Fig. 17's fits as "
        "figures only; the tables give ours.\n\n"
     << "## Time step\n\n" << timeStepSection(cases, o.convergence)
     << "## Cases (Table 1), Fig. 15 means and Fig. 17 fits\n\n" << caseTable(cases)
     << "\n## Tilt of the PMMA tool at 200-400 mm (Section 3)\n\n" << tiltTable(cases)
     << "\n## Computing time beside Table 1\n\nOurs: the built-in DEM on this machine; the projection scales the "
        "full-scale estimate (`demfem validate`) by the measured / estimated cost of the run itself.\n\n"
     << hoursTable(cases) << '\n';
  if (o.renderer) {
    md << "## Figures\n\n"
       << plotFile(out, *o.renderer, "paper_force_curves", curvesFigure(cases, true))
       << plotFile(out, *o.renderer, "paper_deformation_curves", curvesFigure(cases, false))
       << plotFile(out, *o.renderer, "paper_spectra", spectraFigure(cases));
  }
  out.writeText("paper-reproduction.md", md.str());
  nlohmann::json doc{{"cases", nlohmann::json::array()}};
  for (const ReportCase& c : cases) doc["cases"].push_back(caseJson(c));
  return doc;
}

}  // namespace demfem::campaign

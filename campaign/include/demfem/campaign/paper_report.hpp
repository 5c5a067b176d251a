// The paper's stated numbers and the report docs/paper-reproduction.md made from campaign runs
// (`demfem campaign --report`, campaign/paper_campaign.hpp).
//
// Contract
// - paperCases(): the one home of the numbers the paper states in its text and tables: Table 1
//   (tool, DEM-only or DEM-FEM, depth, velocity, measurement time, computing hours on 8 cores) and
//   Section 3's tilt ranges at 200-400 mm of tool displacement (PMMA, measured and simulated) and
//   Section 3.5's soil motion at 300 mm of displacement, 42 mm deep (Fig. 16: the depth of the soil
//   in motion and the speeds directly in front of the tool, PMMA and S235 DEM-FEM, S235 DEM).
//   Fig. 15's means and Fig. 17's fits are given as figures only, so the report lists ours there.
// - A case of the report is a study file; it is matched to the paper's case by its first tool's
//   name ("S235", "PMMA"), its kind and its depth. Its run is the campaign run directory
//   `directory / stem` (campaign/paper_campaign.hpp); a finished run (sensors.json complete) is
//   evaluated (a finished run of another study than the case's file is an ArgumentError).
// - Kept evaluations: every evaluated case is also written to `paper-runs/<case>.json` of the
//   output (its numbers, the curve at one sample per 0.5 mm, the spectrum as means over 50
//   logarithmic bins per decade from 1 Hz, its wall time and estimate, the label of its runs and
//   the FNV-1a 64 of its study's caseIdentity(), notes left out). A case without a finished run
//   takes the evaluation kept in the output directory by an earlier report, if it is of the same
//   case (else the report lists it as not used), so that a report stays whole when only some cases are
//   rerun, on another machine. Plots always show the kept form, so a report from kept evaluations
//   equals the one from the runs. A damaged kept file is an analysis::InputError naming it; a case
//   with neither is listed with its estimated cost only.
// - Evaluation of a finished run (analysis/evaluation.hpp, spectrum.hpp): the run's sensors.csv as
//   a calibrated recording; window statistics over the paper's 100-500 mm, scaled by stroke / 600 mm
//   for a shortened stroke (the same fractions of the stroke); the tilt's range (min, max), mean
//   and standard deviation over 200-400 mm scaled the same way (the report compares the mean with
//   the midpoint of the paper's range); the amplitude spectrum of the deformation over the window (of
//   the force for a rigid tool) and its power-law fit A = a f^b over 1 Hz up to half the sample rate.
// - Soil motion (Fig. 16): a finished run with particle files (output.vtk_every > 0: vtk/particles.pvd)
//   is analysed at 300 mm of displacement, scaled by stroke / 600 mm, by analysis::analyseRun() with
//   analysis::SoilMotionSettings' defaults (in motion above 5 mm/s; in front of the tool: across its
//   width, from its tip to the surface, one largest particle diameter ahead of its front face), as
//   `demfem soil-motion` does. A run without particle files has none; a kept evaluation of an
//   earlier report without the key `soil_motion` has none.
// - Wall time: the run's summed wall time (kRunRecord) and the full-scale projection: the estimate
//   of the study file as given (estimate_wall_s), times measured / estimated of the run itself.
// - Time step: for each of `convergence` (the bench's JSON, campaign/paper_convergence.hpp) its
//   tables and verdict, in order, after the explanation of the step the cases run at.
// - Output: `paper-reproduction.md`, its table `paper-reproduction.csv` (one row per case: the
//   case, its tool, model, depth and velocities, DEM step, whether its evaluation is a kept one
//   and the label of its runs, the run's stroke, window, window means
//   and spreads, spectral fit, tilt range beside the paper's, soil motion beside Fig. 16's, wall time and the full-scale
//   projection beside Table 1's hours; a case not finished has its run's figures empty) and, with a
//   renderer, plots/paper_force_curves.svg, plots/paper_deformation_curves.svg,
//   plots/paper_spectra.svg and, for cases with soil motion, plots/paper_soil_motion.svg (the
//   vertical velocity sections, as `demfem soil-motion` draws them; scripts beside them) in `out` (staged: nothing appears unless
//   everything was written). Every table of the Markdown is a view of that one table (a report
//   section, demfem/analysis/report_section.hpp). Returns the report as JSON: `cases`, one object
//   per case keyed by the CSV's column names, null where the CSV has "nan".
// - Throws ArgumentError for a study that is not a soil-bin case, analysis::InputError for a
//   finished run that cannot be evaluated, analysis::PlotError when gnuplot fails.
#pragma once

#include "demfem/analysis/evaluation.hpp"
#include "demfem/analysis/plot.hpp"
#include "demfem/analysis/soil_motion.hpp"
#include "demfem/analysis/spectrum.hpp"
#include "demfem/analysis/staged_output.hpp"
#include "demfem/campaign/paper_convergence.hpp"
#include "demfem/study/study.hpp"

#include <nlohmann/json.hpp>

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace demfem::campaign {

struct PaperCase {
  std::string tool;  // tools[0].name of the study: "S235" or "PMMA"
  study::StudyKind kind = study::StudyKind::Coupled;
  double depth_mm = 0, velocity_mm_s = 0, measurement_s = 0, hours = 0;
  std::optional<std::pair<double, double>> measured_tilt_deg, simulated_tilt_deg;  // 200-400 mm
  // Section 3.5 at 300 mm of displacement: the depth of the soil in motion and the speed range
  // directly in front of the tool (Fig. 16; the 42 mm cases only).
  std::optional<double> moving_depth_mm;
  std::optional<std::pair<double, double>> front_speed_mm_s;
};

const std::vector<PaperCase>& paperCases();

// The paper's case of a study (nullptr when none matches).
const PaperCase* paperCaseOf(const study::Study& study);

// The soil motion of a run at one tool displacement (see contract; analysis/soil_motion.hpp).
struct SoilMotionEvaluation {
  double displacement_mm = 0;  // of the frame analysed, the nearest to the one asked for
  double moving_depth_mm = 0, moving_length_mm = 0, moving_width_mm = 0;
  std::size_t moving_particles = 0;
  double front_min_mm_s = 0, front_median_mm_s = 0, front_max_mm_s = 0;
  std::size_t front_particles = 0;
  double streamline_order = 0, mean_streamline_length_mm = 0;  // NaN: no cell / no streamline
  std::size_t streamlines = 0;
  // What its plot shows (analysis::sectionsFigure()), kept with the numbers: the vertical section's
  // speeds, the region in motion, the tool's bounds, the surface and the streamlines (m, m/s).
  analysis::SectionMap vertical;
  analysis::Box region, tool;
  double surface_y_m = 0;
  std::vector<analysis::Streamline> streamline_paths;
};

// A finished campaign run evaluated (see contract); wall_s from its kRunRecord.
struct RunEvaluation {
  double stroke_mm = 0, window_begin_mm = 0, window_end_mm = 0, tilt_begin_mm = 0, tilt_end_mm = 0;
  analysis::WindowStatistics window;
  std::optional<std::pair<double, double>> tilt_range_deg;
  std::optional<analysis::SignalStatistics> tilt_window_deg;  // mean and spread over the tilt window
  analysis::PowerLawFit fit;
  std::string fit_signal;  // "deformation" or "force" (rigid tool)
  analysis::Spectrum spectrum;
  analysis::DisplacementCurve curve;
  std::optional<SoilMotionEvaluation> soil_motion;  // a run with particle files only
  double wall_s = 0;
};

// The evaluation of a finished run's sensors (its sensors.csv read as a recording) of `run_study`
// (see contract); wall_s is left 0. Throws analysis::InputError.
RunEvaluation evaluatePaperRun(const analysis::Recording& sensors, const study::Study& run_study);

// Pre: `run_dir` holds a finished run of `run_study`; its soil motion when it has particle files.
// Throws analysis::InputError.
RunEvaluation evaluateCampaignRun(const std::filesystem::path& run_dir, const study::Study& run_study);

struct ReportOptions {
  std::filesystem::path directory = "campaign";  // the campaign's run directories
  std::string label;                              // the source revision the runs came from (kept with each evaluation)
  std::function<double(const study::Study&)> estimate_wall_s;  // required
  const analysis::GnuplotRenderer* renderer = nullptr;         // no plots without
  std::vector<ConvergenceSummary> convergence;                 // the "Time step" section's tables
};

nlohmann::json writePaperReport(const std::vector<std::filesystem::path>& study_files, const ReportOptions& options,
                                analysis::StagedOutput& out);

}  // namespace demfem::campaign

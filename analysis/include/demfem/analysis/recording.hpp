// demfem analysis: reading soil-bin and calibration-weight recordings (docs/architecture.md section 8).
//
// Contract
// - A recording is a CSV file with a header line plus a JSON sidecar of the same stem
//   (`run_03.csv` + `run_03.json`). Columns are found by name (order free, extra columns ignored).
//   Lines starting with '#' are comments; a comment starting with "# incomplete" marks a run that
//   stopped early and is rejected.
// - Two formats, told apart by the name of the time column:
//   * Raw (measured, DAQ units): `t,force,deformation` (t in s). The sidecar gives the case and
//     the calibration: soil bin `{"tool","depth_mm","stroke_mm","sample_rate_hz","force_factor",
//     "deformation_factor","repeat"}`, calibration weight `{"tool","mass_kg","sample_rate_hz",
//     "force_factor","deformation_factor","repeat"}`. force_factor is N per DAQ unit,
//     deformation_factor mm per DAQ unit.
//   * Calibrated (simulated by the FEM client, or already evaluated): `t_s,force_N,deformation_mm`
//     plus `displacement_mm` for soil-bin runs and optionally `tilt_deg`. The sidecar gives the
//     case: `{"tool","depth_mm"}` or `{"tool","mass_kg"}`, optionally "repeat" (default 1),
//     "complete" (false = rejected) and "sample_rate_hz" (checked like a raw one's). Calibration
//     factors in such a sidecar are an error (they would be silently ignored).
//   Exactly one of depth_mm (soil-bin run) and mass_kg (calibration-weight run) must be present;
//   both are rounded to 1e-6 (mm, kg) so case keys compare equal despite float round-off.
// - Post: time strictly increasing, every value finite, at least two samples, and for raw
//   recordings (and calibrated ones whose sidecar gives sample_rate_hz) the median time step agrees
//   with 1/sample_rate_hz within 2 %.
// - Every problem throws InputError whose message starts with "FILE:LINE:COLUMN:" (CSV, 1-based,
//   column = cell index) or "FILE: /json/pointer:" (sidecar), then says what is wrong.
#pragma once

#include <compare>
#include <cstddef>
#include <filesystem>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace demfem::analysis {

// Invalid recording, sidecar or argument: the message names file, line and column (or JSON path).
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum class CaseKind { SoilBin, CalibrationWeight };

// One experimental case: a tool at a working depth (soil bin) or under a calibration weight.
// Repeats of one case share the key; measured and simulated runs of one case are compared.
struct CaseKey {
  CaseKind kind = CaseKind::SoilBin;
  std::string tool;
  double depth_mm = 0.0;  // SoilBin only
  double mass_kg = 0.0;   // CalibrationWeight only

  // File-name friendly label, e.g. "PMMA_18mm" or "PMMA_1kg"; at most 60 characters for a tool name
  // of any length (a long name is cut and keeps a hash of the whole).
  std::string label() const;
  // Human label, e.g. "PMMA, 18 mm depth" or "PMMA, 1 kg weight".
  std::string title() const;
  auto operator<=>(const CaseKey&) const = default;
};

enum class RecordingFormat {
  Raw,         // t,force,deformation in DAQ units; calibration factors in the sidecar
  Calibrated,  // t_s,force_N,deformation_mm[,displacement_mm][,tilt_deg]
};

struct Recording {
  std::filesystem::path csv_path;
  std::filesystem::path sidecar_path;
  RecordingFormat format = RecordingFormat::Raw;
  CaseKey key;
  int repeat = 1;
  // Raw format only (zero otherwise; sample_rate_hz also when a calibrated sidecar gives it).
  // stroke_mm only for soil-bin runs.
  double stroke_mm = 0.0;
  double sample_rate_hz = 0.0;
  double force_factor_N_per_unit = 1.0;
  double deformation_factor_mm_per_unit = 1.0;

  // Samples, one entry per data line. Raw: DAQ units; calibrated: N and mm.
  std::vector<double> time_s;
  std::vector<double> force;
  std::vector<double> deformation;
  std::vector<double> displacement_mm;  // calibrated soil-bin runs only
  std::vector<double> tilt_deg;         // calibrated runs with a tilt_deg column only
  std::vector<std::size_t> line;        // 1-based file line of each sample, for messages

  std::size_t size() const { return time_s.size(); }
};

// Reads one recording and its sidecar (same stem, extension .json). Throws InputError.
Recording readRecording(const std::filesystem::path& csv_path);

// Expands directories to their recordings: the *.csv files that have a .json sidecar (sorted by
// name, not recursive; other CSV files, e.g. the FEM client's keypoints.csv, are not recordings).
// A file given by name must end in .csv and needs its sidecar. Reads every recording, replaces the
// sidecar's tool name by `tool_override` when given (the FEM client names the tool after the
// study's tool entry), and checks that repeats of one case agree (same format and stroke, no
// repeat number twice). Throws InputError; an empty expansion is an error.
std::vector<Recording> readRecordings(const std::vector<std::filesystem::path>& paths,
                                      const std::optional<std::string>& tool_override = std::nullopt);

}  // namespace demfem::analysis

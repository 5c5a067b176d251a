#include "demfem/analysis/recording.hpp"

#include "table_io.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <optional>
#include <sstream>

namespace demfem::analysis {

using nlohmann::json;
using namespace detail;
namespace fs = std::filesystem;

std::string CaseKey::label() const {
  // A file name stays far below the system's 255 bytes: a tool name longer than 40 characters keeps
  // its first 32 and a hash of the whole name, so two long names stay two files.
  constexpr std::size_t kLongName = 40, kKept = 32;
  std::ostringstream out;
  if (tool.size() <= kLongName) out << tool << '_';
  else out << tool.substr(0, kKept) << '-' << std::hex << (std::hash<std::string>{}(tool) & 0xffffffffu) << std::dec << '_';
  if (kind == CaseKind::SoilBin) out << depth_mm << "mm";
  else out << mass_kg << "kg";
  std::string result = out.str();
  for (char& c : result)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')) c = '-';
  return result;
}

std::string CaseKey::title() const {
  std::ostringstream out;
  out << tool << ", ";
  if (kind == CaseKind::SoilBin) out << depth_mm << " mm depth";
  else out << mass_kg << " kg weight";
  return out.str();
}

// What a soil-bin run's depth and a calibration weight can be: a value outside is a unit mistake
// (a depth in metres, a mass in grams) or a corrupted file, never a measurement
// (docs/analysis.md, "Recordings").
constexpr double kDepthRange_mm[2] = {1.0, 1000.0};
constexpr double kMassRange_kg[2] = {1e-3, 100.0};

Recording readRecording(const fs::path& csv_path) {
  Recording rec;
  rec.csv_path = csv_path;
  rec.sidecar_path = fs::path(csv_path).replace_extension(".json");
  const Table table = readTable(csv_path);
  const Sidecar sidecar(rec.sidecar_path);

  // Case from the sidecar.
  rec.key.tool = sidecar.text("tool");
  const bool has_depth = sidecar.has("depth_mm");
  const bool has_mass = sidecar.has("mass_kg");
  if (has_depth == has_mass)
    sidecar.fail(has_depth ? "mass_kg" : "depth_mm",
                 "give exactly one of depth_mm (soil-bin run) and mass_kg (calibration-weight run)");
  // Rounded to 1e-6 mm / 1e-6 kg so a depth written as 0.018 m * 1e3 still matches 18.
  const auto keyValue = [](double value) { return std::round(value * 1e6) / 1e6; };
  if (has_depth) {
    rec.key.kind = CaseKind::SoilBin;
    rec.key.depth_mm = keyValue(sidecar.within("depth_mm", kDepthRange_mm[0], kDepthRange_mm[1], "a working depth in millimetres"));
  } else {
    rec.key.kind = CaseKind::CalibrationWeight;
    rec.key.mass_kg = keyValue(sidecar.within("mass_kg", kMassRange_kg[0], kMassRange_kg[1], "a calibration weight in kilograms"));
  }
  const bool soil_bin = rec.key.kind == CaseKind::SoilBin;

  // Format from the time column.
  const bool raw_time = std::find(table.header.begin(), table.header.end(), "t") != table.header.end();
  const bool calibrated_time = std::find(table.header.begin(), table.header.end(), "t_s") != table.header.end();
  if (raw_time == calibrated_time)
    throw InputError(csv_path.string() + ":" + std::to_string(table.header_line) +
                     (raw_time ? ": both 't' and 't_s' columns: cannot tell raw from calibrated format"
                               : ": missing time column: expected 't' (raw recording, with force, deformation) or 't_s' (calibrated or simulated, with force_N, deformation_mm)"));
  std::vector<ColumnSpec> specs;
  if (raw_time) {
    rec.format = RecordingFormat::Raw;
    specs = {{"t", true, &rec.time_s}, {"force", true, &rec.force}, {"deformation", true, &rec.deformation}};
    rec.repeat = sidecar.repeat(std::nullopt);
    rec.sample_rate_hz = sidecar.positive("sample_rate_hz");
    rec.force_factor_N_per_unit = sidecar.nonzero("force_factor");
    rec.deformation_factor_mm_per_unit = sidecar.nonzero("deformation_factor");
    if (soil_bin) rec.stroke_mm = sidecar.positive("stroke_mm");
  } else {
    rec.format = RecordingFormat::Calibrated;
    specs = {{"t_s", true, &rec.time_s}, {"force_N", true, &rec.force}, {"deformation_mm", true, &rec.deformation},
             {"displacement_mm", soil_bin, &rec.displacement_mm}, {"tilt_deg", false, &rec.tilt_deg}};
    rec.repeat = sidecar.repeat(1);
    if (!sidecar.flag("complete", true)) sidecar.fail("complete", "the run is marked incomplete (complete: false)");
    for (const char* factor : {"force_factor", "deformation_factor"})
      if (sidecar.has(factor))
        sidecar.fail(factor, "given, but " + csv_path.string() + " is already calibrated (column 't_s', N and mm): factors apply to raw " +
                                 "recordings (column 't') only");
    if (sidecar.has("sample_rate_hz")) rec.sample_rate_hz = sidecar.positive("sample_rate_hz");
  }

  std::vector<std::size_t> column_index;
  for (const auto& spec : specs) column_index.push_back(findColumn(table, csv_path, spec.name, spec.required));
  for (std::size_t r = 0; r < table.rows.size(); ++r) {
    for (std::size_t s = 0; s < specs.size(); ++s) {
      const std::size_t c = column_index[s];
      if (c == table.header.size()) continue;  // optional column absent
      specs[s].target->push_back(parseCell(table.rows[r][c], csv_path, table.row_line[r], c, specs[s].name));
    }
    rec.line.push_back(table.row_line[r]);
  }
  if (!soil_bin) rec.displacement_mm.clear();  // a displacement column has no meaning for a weight drop

  if (rec.size() < 2)
    throw InputError(csv_path.string() + ":" + std::to_string(table.header_line) + ": only " + std::to_string(rec.size()) +
                     " data rows (need at least 2)");
  const std::size_t time_column = column_index[0];
  for (std::size_t i = 1; i < rec.size(); ++i) {
    if (!(rec.time_s[i] > rec.time_s[i - 1]))
      throw InputError(csv_path.string() + ":" + std::to_string(rec.line[i]) + ":" + std::to_string(time_column + 1) + ": column '" +
                       specs[0].name + "': time " + formatNumber(rec.time_s[i]) + " s does not increase (previous row, line " +
                       std::to_string(rec.line[i - 1]) + ", has " + formatNumber(rec.time_s[i - 1]) + " s)");
  }
  if (rec.sample_rate_hz > 0.0) {
    std::vector<double> steps(rec.size() - 1);
    for (std::size_t i = 1; i < rec.size(); ++i) steps[i - 1] = rec.time_s[i] - rec.time_s[i - 1];
    std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
    const double median_step = steps[steps.size() / 2];
    const double expected_step = 1.0 / rec.sample_rate_hz;
    if (std::abs(median_step - expected_step) > 0.02 * expected_step)
      sidecar.fail("sample_rate_hz", "does not match the recording: " + formatNumber(rec.sample_rate_hz) + " Hz in the sidecar but column '" + specs[0].name + "' of " +
                                         csv_path.string() + " advances by " + formatNumber(median_step) + " s per row (" +
                                         formatNumber(1.0 / median_step) + " Hz)");
  }
  return rec;
}

std::vector<Recording> readRecordings(const std::vector<fs::path>& paths, const std::optional<std::string>& tool_override) {
  std::vector<fs::path> files;
  for (const auto& path : paths) {
    if (fs::is_directory(path)) {
      std::vector<fs::path> found;
      for (const auto& entry : fs::directory_iterator(path))
        if (entry.is_regular_file() && entry.path().extension() == ".csv" && fs::exists(fs::path(entry.path()).replace_extension(".json")))
          found.push_back(entry.path());
      if (found.empty()) throw InputError(path.string() + ": directory holds no recording (a *.csv file with a .json sidecar of the same stem)");
      std::sort(found.begin(), found.end());
      files.insert(files.end(), found.begin(), found.end());
    } else if (fs::exists(path)) {
      if (path.extension() != ".csv")
        throw InputError(path.string() + ": not a recording (expected a .csv file whose sidecar is the .json of the same stem)");
      files.push_back(path);
    } else {
      throw InputError(path.string() + ": no such file or directory");
    }
  }
  if (files.empty()) throw InputError("no recordings given");

  std::vector<Recording> recordings;
  std::map<CaseKey, std::size_t> first_of_case;
  std::map<std::pair<CaseKey, int>, std::size_t> repeat_owner;
  for (const auto& file : files) {
    Recording rec = readRecording(file);
    if (tool_override) rec.key.tool = *tool_override;
    const auto [it, inserted] = first_of_case.emplace(rec.key, recordings.size());
    if (!inserted) {
      const Recording& first = recordings[it->second];
      if (first.format != rec.format)
        throw InputError(rec.sidecar_path.string() + ": case " + rec.key.title() + " mixes raw and calibrated recordings (" +
                         first.csv_path.string() + " is in the other format)");
      if (first.stroke_mm != rec.stroke_mm)
        throw InputError(rec.sidecar_path.string() + ": /stroke_mm: " + formatNumber(rec.stroke_mm) + " mm differs from " +
                         formatNumber(first.stroke_mm) + " mm in " + first.sidecar_path.string() + " (same case " + rec.key.title() + ")");
    }
    const auto [owner, fresh] = repeat_owner.emplace(std::make_pair(rec.key, rec.repeat), recordings.size());
    if (!fresh)
      throw InputError(rec.sidecar_path.string() + ": /repeat: repeat " + std::to_string(rec.repeat) + " of case " + rec.key.title() +
                       " is also claimed by " + recordings[owner->second].sidecar_path.string());
    recordings.push_back(std::move(rec));
  }
  return recordings;
}

}  // namespace demfem::analysis

#include "demfem/campaign/run_cache.hpp"

#include "demfem/adapter/output_files.hpp"

#include <nlohmann/json.hpp>

#include <cstdio>
#include <fstream>
#include <sstream>
#include <thread>

namespace demfem::campaign {
namespace {

namespace fs = std::filesystem;

// Canonical text: sorted keys, shortest round-trip numbers.
std::string studyText(const study::Study& study) { return nlohmann::json::parse(study::toJson(study).dump()).dump(); }

std::string hex16(std::uint64_t h) {
  char buffer[17];
  std::snprintf(buffer, sizeof buffer, "%016llx", static_cast<unsigned long long>(h));
  return buffer;
}

}  // namespace

RunCache::RunCache(fs::path directory) : directory_(std::move(directory)) {
  std::error_code ec;
  fs::create_directories(directory_, ec);
  if (ec || !fs::is_directory(directory_)) throw std::runtime_error("run cache: cannot create directory " + directory_.string() + ": " + ec.message());
}

std::string RunCache::key(const std::string& model_name, const study::Study& study, const analysis::CaseKey& key) {
  return hex16(study::fnv1a64(model_name + "\n" + studyText(study) + "\n" + key.label()));
}

std::optional<analysis::Recording> RunCache::find(const std::string& model_name, const study::Study& study,
                                                  const analysis::CaseKey& case_key) const {
  const fs::path file = directory_ / (key(model_name, study, case_key) + ".json");
  std::ifstream in(file);
  if (!in) return std::nullopt;
  try {
    const nlohmann::json entry = nlohmann::json::parse(in);
    if (entry.at("model") != model_name || entry.at("case") != case_key.label() || entry.at("study").dump() != studyText(study))
      return std::nullopt;  // a hash collision: recomputed and replaced
    analysis::Recording rec;
    rec.format = analysis::RecordingFormat::Calibrated;
    rec.key = case_key;
    rec.csv_path = file;
    const auto& columns = entry.at("columns");
    rec.time_s = columns.at("t_s").get<std::vector<double>>();
    rec.force = columns.at("force_N").get<std::vector<double>>();
    rec.deformation = columns.at("deformation_mm").get<std::vector<double>>();
    rec.displacement_mm = columns.at("displacement_mm").get<std::vector<double>>();
    if (rec.force.size() != rec.size() || rec.deformation.size() != rec.size()) return std::nullopt;
    rec.line.resize(rec.size());
    for (std::size_t i = 0; i < rec.size(); ++i) rec.line[i] = i + 1;
    return rec;
  } catch (const nlohmann::json::exception&) {
    return std::nullopt;  // unreadable entry (e.g. from an older version): recomputed and replaced
  }
}

void RunCache::store(const std::string& model_name, const study::Study& study, const analysis::CaseKey& case_key,
                     const analysis::Recording& recording) const {
  const nlohmann::json entry = {{"model", model_name},
                                {"case", case_key.label()},
                                {"study", nlohmann::json::parse(studyText(study))},
                                {"columns",
                                 {{"t_s", recording.time_s},
                                  {"force_N", recording.force},
                                  {"deformation_mm", recording.deformation},
                                  {"displacement_mm", recording.displacement_mm}}}};
  const fs::path file = directory_ / (key(model_name, study, case_key) + ".json");
  try {
    adapter::writeFileAtomically(file, entry.dump());
  } catch (const adapter::OutputError& e) {
    throw std::runtime_error(std::string("run cache: ") + e.what());
  }
}

}  // namespace demfem::campaign

// Shared test fixture: the shipped studies (studies/*.json) made small enough for a test, one
// change at a time on the study's JSON, so every test that shrinks a study shrinks it the same way
// and says in its own comment what it changed beyond these.
#pragma once

#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>

namespace demfem::support {

// studies/<file> of the source tree as JSON. Throws std::runtime_error when it cannot be read.
inline nlohmann::json shippedStudyJson(const std::string& file) {
  const std::filesystem::path path = std::filesystem::path(DEMFEM_SOURCE_DIR) / "studies" / file;
  std::ifstream in(path);
  if (!in) throw std::runtime_error("cannot read " + path.string());
  std::stringstream text;
  text << in.rdbuf();
  return nlohmann::json::parse(text.str());
}

// The first tool 120 x 20 mm (a 5 x 25 x 2 = 250-keypoint plate: a quick reduction).
inline void useSmallTool(nlohmann::json& study) {
  study["tools"][0]["geometry"]["length_mm"] = 120;
  study["tools"][0]["geometry"]["width_mm"] = 20;
}

// A `length_mm` x 80 mm bin filled 40 mm deep (the deepest of the four layers of studies/quick*.json
// ends at the fill): about 500 particles at 140 mm.
inline void useSmallBin(nlohmann::json& study, double length_mm = 140) {
  auto& soil = study["soil"];
  soil["bin"]["length_mm"] = length_mm;
  soil["bin"]["width_mm"] = 80;
  soil["fill_height_mm"] = 40;
  soil["layers"][3]["bottom_depth_mm"] = 40;
}

// The first tool inserted at 300 mm/s from z = 40 mm and dragged `stroke_mm` at 100 mm/s.
inline void useShortStroke(nlohmann::json& study, double stroke_mm) {
  auto& motion = study["tools"][0]["motion"];
  motion["insertion_velocity_mm_s"] = 300;
  motion["velocity_mm_s"] = 100;
  motion["stroke_mm"] = stroke_mm;
  motion["start_z_mm"] = 40;
}

// Writes `study` (indented) to `file` and returns the file. Throws std::runtime_error when it fails.
inline std::filesystem::path writeStudy(const nlohmann::json& study, const std::filesystem::path& file) {
  std::ofstream out(file);
  out << study.dump(2);
  if (!out) throw std::runtime_error("cannot write " + file.string());
  return file;
}

}  // namespace demfem::support

// The study tests' access to files of the source tree (studies/, docs/, tests/study/data/).
#pragma once

#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace demfem::study::testing {

inline const std::filesystem::path kSource = DEMFEM_SOURCE_DIR;

// The whole text of `file`; the test fails if it cannot be opened.
inline std::string readText(const std::filesystem::path& file) {
  std::ifstream in(file);
  REQUIRE(in);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

}  // namespace demfem::study::testing

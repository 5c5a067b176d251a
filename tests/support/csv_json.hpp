// Shared test fixture: a report table's CSV against its JSON document. Both are generated from one
// declaration of the table's columns (demfem/analysis/report_section.hpp), so every CSV cell must
// equal the value of its column in the JSON row of the same index.
#pragma once

#include <catch2/catch.hpp>
#include <nlohmann/json.hpp>

#include <sstream>
#include <string>
#include <vector>

namespace demfem::support {

// The cells of one CSV line (RFC 4180 quoting: "a, b" and "say ""x""").
inline std::vector<std::string> csvCells(const std::string& line) {
  std::vector<std::string> cells(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted && c == '"' && i + 1 < line.size() && line[i + 1] == '"') cells.back() += '"', ++i;
    else if (c == '"') quoted = !quoted;
    else if (c == ',' && !quoted) cells.emplace_back();
    else cells.back() += c;
  }
  return cells;
}

// Every cell of the CSV table `csv` equals the value of its column in the JSON row of the same index
// (the CSV's %.10g numbers to 1e-9, text as it is, "nan" for null, "true"/"false" for flags), and
// the table has as many rows as the JSON array.
inline void checkCsvMatchesJson(const std::string& csv, const nlohmann::json& rows) {
  REQUIRE(rows.is_array());
  std::istringstream lines(csv);
  std::string line;
  REQUIRE(std::getline(lines, line));
  const std::vector<std::string> header = csvCells(line);
  std::size_t row = 0;
  for (; std::getline(lines, line); ++row) {
    REQUIRE(row < rows.size());
    const std::vector<std::string> cells = csvCells(line);
    REQUIRE(cells.size() == header.size());
    for (std::size_t i = 0; i < header.size(); ++i) {
      INFO("column " << header[i] << ", row " << row);
      const nlohmann::json& value = rows[row].at(header[i]);
      if (value.is_null()) CHECK(cells[i] == "nan");
      else if (value.is_number()) CHECK(std::stod(cells[i]) == Approx(value.get<double>()).epsilon(1e-9));
      else if (value.is_boolean()) CHECK(cells[i] == (value.get<bool>() ? "true" : "false"));
      else CHECK(cells[i] == value.get<std::string>());
    }
  }
  CHECK(row == rows.size());
}

// The arrays `key` of every object of `parents`, one after another (a table the JSON nests per
// stage or per cause and the CSV writes as one).
inline nlohmann::json nestedRows(const nlohmann::json& parents, const std::string& key) {
  nlohmann::json all = nlohmann::json::array();
  for (const nlohmann::json& parent : parents)
    for (const nlohmann::json& row : parent.at(key)) all.push_back(row);
  return all;
}

}  // namespace demfem::support

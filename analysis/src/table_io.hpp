// Internal to the analysis library: the CSV tables and JSON sidecars of recordings and measured
// profiles (the rules of recording.hpp's contract), shared by recording.cpp and cone_penetration.cpp.
#pragma once

#include "demfem/analysis/recording.hpp"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstddef>
#include <fstream>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace demfem::analysis::detail {

std::string formatNumber(double value);
std::string trim(std::string_view text);
std::vector<std::string> splitCells(const std::string& line);

// --- sidecar --------------------------------------------------------------------------------

class Sidecar {
 public:
  Sidecar(std::filesystem::path path) : path_(std::move(path)) {
    std::ifstream in(path_);
    if (!in) throw InputError(path_.string() + ": cannot open the sidecar (every recording needs a JSON file of the same stem)");
    try {
      doc_ = nlohmann::json::parse(in);
    } catch (const nlohmann::json::parse_error& e) {
      throw InputError(path_.string() + ": byte " + std::to_string(e.byte) + ": not valid JSON (" + e.what() + ")");
    }
    if (!doc_.is_object()) throw InputError(path_.string() + ": /: expected a JSON object");
  }

  bool has(const std::string& key) const { return doc_.contains(key); }

  [[noreturn]] void fail(const std::string& key, const std::string& message) const {
    throw InputError(path_.string() + ": /" + key + ": " + message);
  }

  double number(const std::string& key) const {
    if (!has(key)) fail(key, "missing (required number)");
    const nlohmann::json& value = doc_.at(key);
    if (!value.is_number()) fail(key, "expected a number, found " + std::string(value.type_name()));
    const double result = value.get<double>();
    if (!std::isfinite(result)) fail(key, "must be finite");
    return result;
  }

  double positive(const std::string& key) const {
    const double value = number(key);
    if (!(value > 0.0)) fail(key, "must be > 0, found " + formatNumber(value));
    return value;
  }

  // A number within [lo, hi] (units in the key's name); `hint` says what a value outside suggests.
  double within(const std::string& key, double lo, double hi, const std::string& hint) const {
    const double value = number(key);
    if (!(value >= lo && value <= hi))
      fail(key, "must be within " + formatNumber(lo) + " to " + formatNumber(hi) + ", found " + formatNumber(value) + " (" + hint + ")");
    return value;
  }

  double nonzero(const std::string& key) const {
    const double value = number(key);
    if (value == 0.0) fail(key, "must not be 0 (it scales DAQ units to physical units)");
    return value;
  }

  int repeat(std::optional<int> default_value) const {
    if (!has("repeat")) {
      if (default_value) return *default_value;
      fail("repeat", "missing (required integer >= 1)");
    }
    const nlohmann::json& value = doc_.at("repeat");
    if (!value.is_number_integer() || value.get<long long>() < 1) fail("repeat", "expected an integer >= 1, found " + value.dump());
    return value.get<int>();
  }

  std::string text(const std::string& key) const {
    if (!has(key)) fail(key, "missing (required string)");
    const nlohmann::json& value = doc_.at(key);
    if (!value.is_string() || value.get<std::string>().empty()) fail(key, "expected a non-empty string, found " + value.dump());
    const std::string text = value.get<std::string>();
    // A name is one line of text: it reaches titles, file names and plot scripts (docs/reliability.md).
    for (const char c : text)
      if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) fail(key, "contains a control character (a name is one line of printable text): " + value.dump());
    return text;
  }

  bool flag(const std::string& key, bool default_value) const {
    if (!has(key)) return default_value;
    const nlohmann::json& value = doc_.at(key);
    if (!value.is_boolean()) fail(key, "expected true or false, found " + value.dump());
    return value.get<bool>();
  }

 private:
  std::filesystem::path path_;
  nlohmann::json doc_;
};

// --- CSV -------------------------------------------------------------------------------------

struct ColumnSpec {
  std::string name;
  bool required;
  std::vector<double>* target;
};

struct Table {
  std::vector<std::string> header;
  std::size_t header_line = 0;
  std::vector<std::vector<std::string>> rows;
  std::vector<std::size_t> row_line;
};

Table readTable(const std::filesystem::path& path);
std::size_t findColumn(const Table& table, const std::filesystem::path& path, const std::string& name, bool required);
double parseCell(const std::string& cell, const std::filesystem::path& path, std::size_t line, std::size_t column, const std::string& name);

}  // namespace demfem::analysis::detail

#include "table_io.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <sstream>

namespace demfem::analysis::detail {

namespace fs = std::filesystem;

std::string formatNumber(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

std::string trim(std::string_view text) {
  const auto first = text.find_first_not_of(" \t\r");
  if (first == std::string_view::npos) return {};
  const auto last = text.find_last_not_of(" \t\r");
  return std::string(text.substr(first, last - first + 1));
}

std::vector<std::string> splitCells(const std::string& line) {
  std::vector<std::string> cells;
  std::size_t begin = 0;
  while (true) {
    const auto comma = line.find(',', begin);
    cells.push_back(trim(std::string_view(line).substr(begin, comma == std::string::npos ? std::string::npos : comma - begin)));
    if (comma == std::string::npos) break;
    begin = comma + 1;
  }
  return cells;
}

Table readTable(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path.string() + ": cannot open the recording");
  Table table;
  std::string raw;
  std::size_t line_number = 0;
  while (std::getline(in, raw)) {
    ++line_number;
    if (line_number == 1 && raw.rfind("\xEF\xBB\xBF", 0) == 0) raw.erase(0, 3);  // UTF-8 byte order mark
    const std::string line = trim(raw);
    if (line.empty()) continue;
    if (line.front() == '#') {
      if (line.rfind("# incomplete", 0) == 0)
        throw InputError(path.string() + ":" + std::to_string(line_number) + ":1: the recording is marked incomplete (" + line + ")");
      continue;
    }
    if (table.header.empty()) {
      table.header = splitCells(line);
      table.header_line = line_number;
      continue;
    }
    auto cells = splitCells(line);
    if (cells.size() != table.header.size()) {
      std::string detail;
      if (cells.size() < table.header.size())
        detail = "column '" + table.header[cells.size()] + "' (" + std::to_string(cells.size() + 1) + ") is missing";
      else
        detail = "cell " + std::to_string(table.header.size() + 1) + " has no column in the header";
      throw InputError(path.string() + ":" + std::to_string(line_number) + ":" + std::to_string(std::min(cells.size(), table.header.size()) + 1) +
                       ": row has " + std::to_string(cells.size()) + " cells but the header (line " + std::to_string(table.header_line) +
                       ") has " + std::to_string(table.header.size()) + ": " + detail);
    }
    table.rows.push_back(std::move(cells));
    table.row_line.push_back(line_number);
  }
  if (table.header.empty()) throw InputError(path.string() + ": empty file (expected a header line)");
  return table;
}

std::size_t findColumn(const Table& table, const fs::path& path, const std::string& name, bool required) {
  const auto it = std::find(table.header.begin(), table.header.end(), name);
  if (it == table.header.end()) {
    if (!required) return table.header.size();
    std::string present;
    for (const auto& h : table.header) present += (present.empty() ? "'" : ", '") + h + "'";
    throw InputError(path.string() + ":" + std::to_string(table.header_line) + ": missing column '" + name + "' (header has " + present + ")");
  }
  if (std::find(it + 1, table.header.end(), name) != table.header.end())
    throw InputError(path.string() + ":" + std::to_string(table.header_line) + ": column '" + name + "' appears twice in the header");
  return static_cast<std::size_t>(it - table.header.begin());
}

double parseCell(const std::string& cell, const fs::path& path, std::size_t line, std::size_t column, const std::string& name) {
  double value = 0.0;
  const char* begin = cell.data();
  const char* end = cell.data() + cell.size();
  if (!cell.empty() && *begin == '+') ++begin;
  const auto [ptr, ec] = std::from_chars(begin, end, value);
  const std::string where = path.string() + ":" + std::to_string(line) + ":" + std::to_string(column + 1) + ": column '" + name + "': ";
  if (cell.empty()) throw InputError(where + "empty cell (expected a number)");
  if (ec != std::errc() || ptr != end) throw InputError(where + "cannot read '" + cell + "' as a number");
  if (!std::isfinite(value)) throw InputError(where + "'" + cell + "' is not a finite number");
  return value;
}

}  // namespace demfem::analysis::detail

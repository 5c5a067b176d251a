// The rendering of report sections (demfem/analysis/report_section.hpp).
#include "demfem/analysis/report_section.hpp"

#include <cmath>
#include <cstdio>
#include <sstream>
#include <stdexcept>

namespace demfem::analysis::report {

std::string num(double value) {
  if (!std::isfinite(value)) return "nan";
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.10g", value);
  return buffer;
}

std::string shortNum(double value, int digits) {
  if (!std::isfinite(value)) return "-";
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.*g", digits, value);
  return buffer;
}

std::string formatted(const char* format, double value) {
  if (!std::isfinite(value)) return "-";
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, value);
  return buffer;
}

std::string plusMinus(double mean, double spread, int digits) {
  return std::isfinite(spread) ? shortNum(mean, digits) + " ± " + shortNum(spread, 3) : shortNum(mean, digits);
}

namespace {

struct CsvText {
  std::string operator()(double v) const { return num(v); }
  std::string operator()(const std::optional<double>& v) const { return v ? num(*v) : std::string("nan"); }
  std::string operator()(const std::string& v) const { return v; }
  std::string operator()(long long v) const { return std::to_string(v); }
  std::string operator()(bool v) const { return v ? "true" : "false"; }
};

struct JsonValue {
  nlohmann::json operator()(double v) const { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); }
  nlohmann::json operator()(const std::optional<double>& v) const { return v ? (*this)(*v) : nlohmann::json(nullptr); }
  nlohmann::json operator()(const std::string& v) const { return v; }
  nlohmann::json operator()(long long v) const { return v; }
  nlohmann::json operator()(bool v) const { return v; }
};

}  // namespace

std::string csvText(const CellValue& value) { return std::visit(CsvText{}, value); }

nlohmann::json jsonOf(const CellValue& value) { return std::visit(JsonValue{}, value); }

bool inCsv(Output output) {
  switch (output) {
    case Output::CsvAndJson: return true;
    case Output::JsonOnly: return false;
    case Output::MarkdownOnly: return false;
  }
  return false;
}

bool inJson(Output output) {
  switch (output) {
    case Output::CsvAndJson: return true;
    case Output::JsonOnly: return true;
    case Output::MarkdownOnly: return false;
  }
  return false;
}

const CellValue& RowValues::operator[](const std::string& name) const {
  for (const auto& [n, v] : cells_)
    if (n == name) return v;
  throw std::logic_error("report section: no column '" + name + "'");
}

double RowValues::number(const std::string& name) const {
  const CellValue& v = (*this)[name];
  if (const auto* d = std::get_if<double>(&v)) return *d;
  if (const auto* o = std::get_if<std::optional<double>>(&v)) return o->value_or(std::nan(""));
  if (const auto* n = std::get_if<long long>(&v)) return static_cast<double>(*n);
  throw std::logic_error("report section: column '" + name + "' is not a number");
}

bool RowValues::flag(const std::string& name) const {
  const CellValue& v = (*this)[name];
  if (const auto* b = std::get_if<bool>(&v)) return *b;
  throw std::logic_error("report section: column '" + name + "' is not a flag");
}

namespace md {

MarkdownCell text(const std::string& column) {
  return [column](const RowValues& v) { return csvText(v[column]); };
}

MarkdownCell number(const std::string& column, int digits) {
  return [column, digits](const RowValues& v) { return shortNum(v.number(column), digits); };
}

MarkdownCell plusMinus(const std::string& mean, const std::string& spread, int digits) {
  return [mean, spread, digits](const RowValues& v) { return report::plusMinus(v.number(mean), v.number(spread), digits); };
}

MarkdownCell format(const std::string& column, const char* format) {
  return [column, format](const RowValues& v) { return formatted(format, v.number(column)); };
}

MarkdownCell literal(std::string text) {
  return [text = std::move(text)](const RowValues&) { return text; };
}

MarkdownCell concat(std::vector<MarkdownCell> parts) {
  return [parts = std::move(parts)](const RowValues& v) {
    std::string out;
    for (const MarkdownCell& p : parts) out += p(v);
    return out;
  };
}

MarkdownCell onlyIf(const std::string& flag_column, MarkdownCell cell, std::string otherwise) {
  return [flag_column, cell = std::move(cell), otherwise = std::move(otherwise)](const RowValues& v) {
    return v.flag(flag_column) ? cell(v) : otherwise;
  };
}

MarkdownCell ifDefined(const std::string& number_column, MarkdownCell cell, std::string otherwise) {
  return [number_column, cell = std::move(cell), otherwise = std::move(otherwise)](const RowValues& v) {
    return std::isfinite(v.number(number_column)) ? cell(v) : otherwise;
  };
}

}  // namespace md

std::string markdownTable(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows) {
  std::ostringstream out;
  out << '|';
  for (const auto& h : header) out << ' ' << h << " |";
  out << "\n|";
  for (std::size_t i = 0; i < header.size(); ++i) out << " --- |";
  out << '\n';
  for (const auto& row : rows) {
    out << '|';
    for (const auto& cell : row) out << ' ' << cell << " |";
    out << '\n';
  }
  return out.str();
}

std::string csvTable(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows) {
  std::ostringstream out;
  const auto line = [&out](const std::vector<std::string>& cells) {
    for (std::size_t i = 0; i < cells.size(); ++i) {
      const bool quote = cells[i].find_first_of(",\"") != std::string::npos;
      out << (i ? "," : "");
      if (quote) {
        out << '"';
        for (char c : cells[i]) out << (c == '"' ? "\"\"" : std::string(1, c));
        out << '"';
      } else {
        out << cells[i];
      }
    }
    out << '\n';
  };
  line(header);
  for (const auto& row : rows) line(row);
  return out.str();
}

}  // namespace demfem::analysis::report

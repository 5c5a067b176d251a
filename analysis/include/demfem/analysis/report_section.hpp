// Report sections: a report table declared once, as columns, and rendered as CSV, Markdown and JSON
// from that declaration (docs/analysis.md; docs/architecture.md section 8). Used by `demfem
// evaluate` / `demfem compare` (analysis/src/report_sections.cpp) and by the reports of the loops
// that rerun the model (campaign/: calibrate, diagnose, the paper campaign).
//
// Contract
// - A Column names one value of a row: its name is the CSV header and the JSON key, with the unit
//   in it (`force_mean_N`, `error_after_percent`; no unit for a ratio or a count), and its getter
//   gives the value of a row. Where a column appears is its Output: CSV and JSON, JSON only (a
//   quantity the JSON document carries that the CSV table leaves out) or Markdown only (text the
//   Markdown table shows that the CSV and JSON give as a table of their own).
// - CSV (Section::csv): a header line of the CSV columns' names, one line per row in the order
//   given; numbers as %.10g ("nan" when not finite or absent), flags "true" / "false", a cell with a
//   comma or a quote quoted (RFC 4180).
// - JSON (Section::json): an array of one object per row keyed by column name; numbers that are not
//   finite or absent are null. Every CSV cell of a row equals the value of the same key of its JSON
//   object (numbers to the CSV's ten digits).
// - Markdown (Section::markdownOf): the first column is the row's title under `title_heading`, the
//   others are MarkdownColumns whose cells are formed from the row's values looked up by column
//   name (md::number, md::plusMinus, ...), never read from the results a second time. One section
//   may be shown as several Markdown tables (views) over the same columns.
// - A Markdown cell that names a column the section does not have, or reads a number from text,
//   throws std::logic_error naming the column: a section declared wrongly, found by its first use.
// - Nothing here knows what the rows are: sections of any library (analysis, campaign) use it.
#pragma once

#include <nlohmann/json.hpp>

#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace demfem::analysis::report {

// CSV number: %.10g, "nan" when not finite.
std::string num(double value);
// Markdown number: %.*g, "-" when not finite.
std::string shortNum(double value, int digits = 4);
// Markdown number in a printf format taking one double ("%.2f", "%+.2f", "%.0f s"); "-" when not finite.
std::string formatted(const char* format, double value);
// Markdown "mean ± spread"; just the mean when the spread is not finite.
std::string plusMinus(double mean, double spread, int digits = 4);

// The value of a cell: a number (not finite: undefined), a number that may be absent, text, a
// count or a flag.
using CellValue = std::variant<double, std::optional<double>, std::string, long long, bool>;

// Its CSV text: num() for numbers ("nan" when absent), the text, the count, "true"/"false".
std::string csvText(const CellValue& value);
// Its JSON value: null for a number that is not finite or absent.
nlohmann::json jsonOf(const CellValue& value);

// A row's cell values by column name.
class RowValues {
 public:
  void add(std::string name, CellValue value) { cells_.emplace_back(std::move(name), std::move(value)); }
  // Throws std::logic_error naming `name` when no column has it (a section declared wrongly).
  const CellValue& operator[](const std::string& name) const;
  // The value as a number: absent -> NaN, a count as it is; throws std::logic_error for text or a flag.
  double number(const std::string& name) const;
  bool flag(const std::string& name) const;

 private:
  std::vector<std::pair<std::string, CellValue>> cells_;
};

// Where a column appears (see the contract).
enum class Output { CsvAndJson, JsonOnly, MarkdownOnly };

bool inCsv(Output output);
bool inJson(Output output);

template <class Row>
struct Column {
  std::string name;  // CSV header and JSON key (the unit in the name: force_mean_N)
  std::function<CellValue(const Row&)> value;
  Output output = Output::CsvAndJson;
};

// A Markdown table cell formed from a row's values.
using MarkdownCell = std::function<std::string(const RowValues&)>;

struct MarkdownColumn {
  std::string heading;
  MarkdownCell cell;
};

namespace md {
MarkdownCell text(const std::string& column);                            // csvText()
MarkdownCell number(const std::string& column, int digits = 4);         // shortNum()
MarkdownCell format(const std::string& column, const char* format);    // formatted()
MarkdownCell plusMinus(const std::string& mean, const std::string& spread, int digits = 4);
MarkdownCell literal(std::string text);
MarkdownCell concat(std::vector<MarkdownCell> parts);                   // the parts one after another
// `cell` when the flag column is true, else `otherwise`.
MarkdownCell onlyIf(const std::string& flag_column, MarkdownCell cell, std::string otherwise = "-");
// `cell` when the number column is finite (not absent), else `otherwise`.
MarkdownCell ifDefined(const std::string& number_column, MarkdownCell cell, std::string otherwise = "-");
}  // namespace md

// A Markdown table from its header and rows of cells.
std::string markdownTable(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows);
// A CSV table (cells with a comma or a quote quoted).
std::string csvTable(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows);

// One table of a report: its columns, the title of a row (the Markdown table's first column,
// headed `title_heading`) and the Markdown table's other columns. A section without Markdown
// columns is only written as CSV and JSON.
template <class Row>
struct Section {
  std::vector<Column<Row>> columns;
  std::function<std::string(const Row&)> title;
  std::vector<MarkdownColumn> markdown;
  std::string title_heading = "case";

  RowValues values(const Row& row) const {
    RowValues v;
    for (const Column<Row>& c : columns) v.add(c.name, c.value(row));
    return v;
  }

  std::string csv(const std::vector<Row>& rows) const {
    std::vector<std::string> header;
    for (const Column<Row>& c : columns)
      if (inCsv(c.output)) header.push_back(c.name);
    std::vector<std::vector<std::string>> cells;
    for (const Row& row : rows) {
      std::vector<std::string>& line = cells.emplace_back();
      for (const Column<Row>& c : columns)
        if (inCsv(c.output)) line.push_back(csvText(c.value(row)));
    }
    return csvTable(header, cells);
  }

  // One row's JSON object: every column but the Markdown-only ones.
  nlohmann::json json(const Row& row) const {
    nlohmann::json object = nlohmann::json::object();
    for (const Column<Row>& c : columns)
      if (inJson(c.output)) object[c.name] = jsonOf(c.value(row));
    return object;
  }

  // A JSON array of one object per row.
  nlohmann::json json(const std::vector<Row>& rows) const {
    nlohmann::json array = nlohmann::json::array();
    for (const Row& row : rows) array.push_back(json(row));
    return array;
  }

  std::string markdownOf(const std::vector<Row>& rows) const { return markdownOf(rows, markdown); }

  // Another Markdown view of the same columns.
  std::string markdownOf(const std::vector<Row>& rows, const std::vector<MarkdownColumn>& view) const {
    std::vector<std::string> header{title_heading};
    for (const MarkdownColumn& c : view) header.push_back(c.heading);
    std::vector<std::vector<std::string>> cells;
    for (const Row& row : rows) {
      const RowValues v = values(row);
      std::vector<std::string>& line = cells.emplace_back();
      line.push_back(title(row));
      for (const MarkdownColumn& c : view) line.push_back(c.cell(v));
    }
    return markdownTable(header, cells);
  }
};

}  // namespace demfem::analysis::report

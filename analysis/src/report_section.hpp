// Report sections of `demfem evaluate` and `demfem compare` (report_sections.hpp; docs/analysis.md):
// each table is declared once, as columns (the name, with the unit in it, and the getter of the
// value for a row). The CSV table is generated from the columns, and so is the Markdown table: its
// cells are formed from the columns' values, looked up by column name (md::number, md::plusMinus,
// ...), never read from the results a second time; and so is the JSON: one object per row, keyed
// by column name (Section::json). A column may be marked JSON-only: a quantity the JSON document
// carries that the CSV table leaves out.
#pragma once

#include <nlohmann/json.hpp>

#include <functional>
#include <optional>
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace demfem::analysis::detail {

// CSV number: %.10g, "nan" when not finite.
std::string num(double value);
// Markdown number: %.*g, "-" when not finite.
std::string shortNum(double value, int digits = 4);
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
  // A JSON object of every column, keyed by column name (jsonOf() of each value).
  nlohmann::json json() const;

 private:
  std::vector<std::pair<std::string, CellValue>> cells_;
};

// Where a column appears: the CSV table and the JSON document, or the JSON document only.
enum class Output { CsvAndJson, JsonOnly };

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
MarkdownCell plusMinus(const std::string& mean, const std::string& spread, int digits = 4);
MarkdownCell literal(std::string text);
MarkdownCell concat(std::vector<MarkdownCell> parts);                   // the parts one after another
MarkdownCell onlyIf(const std::string& flag_column, MarkdownCell cell);  // "-" unless the flag is true
}  // namespace md

// A Markdown table from its header and rows of cells.
std::string markdownTable(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows);
// A CSV table (cells with a comma or a quote quoted).
std::string csvTable(const std::vector<std::string>& header, const std::vector<std::vector<std::string>>& rows);

// One table of a report: its columns, the case title of a row (the Markdown table's first column,
// "case") and the Markdown table's other columns. A section without Markdown columns is only
// written as JSON.
template <class Row>
struct Section {
  std::vector<Column<Row>> columns;
  std::function<std::string(const Row&)> title;
  std::vector<MarkdownColumn> markdown;

  RowValues values(const Row& row) const {
    RowValues v;
    for (const Column<Row>& c : columns) v.add(c.name, c.value(row));
    return v;
  }

  std::string csv(const std::vector<Row>& rows) const {
    std::vector<std::string> header;
    for (const Column<Row>& c : columns)
      if (c.output == Output::CsvAndJson) header.push_back(c.name);
    std::vector<std::vector<std::string>> cells;
    for (const Row& row : rows) {
      std::vector<std::string>& line = cells.emplace_back();
      for (const Column<Row>& c : columns)
        if (c.output == Output::CsvAndJson) line.push_back(csvText(c.value(row)));
    }
    return csvTable(header, cells);
  }

  // A JSON array of one object per row (RowValues::json), JSON-only columns included.
  nlohmann::json json(const std::vector<Row>& rows) const {
    nlohmann::json array = nlohmann::json::array();
    for (const Row& row : rows) array.push_back(values(row).json());
    return array;
  }

  std::string markdownOf(const std::vector<Row>& rows) const {
    std::vector<std::string> header{"case"};
    for (const MarkdownColumn& c : markdown) header.push_back(c.heading);
    std::vector<std::vector<std::string>> cells;
    for (const Row& row : rows) {
      const RowValues v = values(row);
      std::vector<std::string>& line = cells.emplace_back();
      line.push_back(title(row));
      for (const MarkdownColumn& c : markdown) line.push_back(c.cell(v));
    }
    return markdownTable(header, cells);
  }
};

}  // namespace demfem::analysis::detail

// The columns of the fitted-parameter table (parameter_section.hpp).
#include "parameter_section.hpp"

namespace demfem::campaign {

using namespace analysis::report;

Section<ParameterRow> parameterSection(const std::string& owner_column) {
  using R = ParameterRow;
  return Section<R>{
      {{owner_column, [](const R& r) { return r.owner; }},
       {"pointer", [](const R& r) -> CellValue { return r.parameter->spec.pointer; }},
       {"label", [](const R& r) -> CellValue { return r.parameter->spec.label(); }},
       {"lo", [](const R& r) -> CellValue { return r.parameter->spec.lo; }},
       {"hi", [](const R& r) -> CellValue { return r.parameter->spec.hi; }},
       {"log", [](const R& r) -> CellValue { return r.parameter->spec.log; }},
       {"initial", [](const R& r) -> CellValue { return r.parameter->initial; }},
       {"value", [](const R& r) -> CellValue { return r.parameter->value; }},
       {"std_dev", [](const R& r) -> CellValue { return r.parameter->std_dev; }},
       {"identified", [](const R& r) -> CellValue { return r.parameter->identified; }},
       {"best_point", [](const R& r) -> CellValue { return r.parameter->best; }}},
      [](const R& r) { return "`" + r.parameter->spec.pointer + "`"; },
      {{"initial", md::number("initial", 6)},
       {"fitted", md::onlyIf("identified", md::number("value", 6), "unidentified")},
       {"std dev", md::number("std_dev", 6)},
       {"bounds", md::concat({md::number("lo", 6), md::literal(" - "), md::number("hi", 6), md::onlyIf("log", md::literal(" (log)"), "")})}},
      "parameter"};
}

std::vector<ParameterRow> parameterRows(const CellValue& owner, const std::vector<FittedParameter>& parameters) {
  std::vector<ParameterRow> rows;
  for (const FittedParameter& p : parameters) rows.push_back({owner, &p});
  return rows;
}

}  // namespace demfem::campaign

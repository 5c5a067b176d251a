#include "demfem/campaign/parameters.hpp"

#include "demfem/study/study.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <set>
#include <sstream>

namespace demfem::campaign {
namespace {

std::string quoted(const ParameterSpec& spec) {
  return "--fit '" + (spec.argument.empty() ? spec.pointer : spec.argument) + "'";
}

double parseNumber(const std::string& text, const std::string& argument, const char* what) {
  double value = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), value);
  if (ec != std::errc() || end != text.data() + text.size() || !std::isfinite(value))
    throw ArgumentError("--fit '" + argument + "': " + what + " '" + text + "' is not a finite number");
  return value;
}

std::vector<std::string> split(const std::string& text, char separator) {
  std::vector<std::string> parts;
  std::stringstream in(text);
  std::string part;
  while (std::getline(in, part, separator)) parts.push_back(part);
  if (!text.empty() && text.back() == separator) parts.emplace_back();
  return parts;
}

nlohmann::ordered_json::json_pointer pointerOf(const ParameterSpec& spec) {
  try {
    return nlohmann::ordered_json::json_pointer(spec.pointer);
  } catch (const nlohmann::json::exception& e) {
    throw ArgumentError(quoted(spec) + ": '" + spec.pointer + "' is not a JSON pointer (" + e.what() + ")");
  }
}

// The study loader's verdict on the study with `spec` set to `value`.
void checkLoadable(const nlohmann::ordered_json& study_json, const std::string& origin, const ParameterSpec& spec, double value,
                   const char* bound) {
  try {
    study::parseStudy(withValues(study_json, {spec}, {value}).dump(), origin);
  } catch (const study::StudyError& e) {
    std::string issues;
    for (const auto& issue : e.issues()) issues += (issues.empty() ? "" : "; ") + issue.path + ": " + issue.message;
    std::ostringstream v;
    v << value;
    throw ArgumentError(quoted(spec) + ": the " + bound + " bound " + v.str() + " is outside the study's valid range (" + issues + ")");
  }
}

}  // namespace

double ParameterSpec::toValue(double unit) const {
  const double x = std::clamp(unit, 0.0, 1.0);
  return log ? lo * std::pow(hi / lo, x) : lo + (hi - lo) * x;
}

double ParameterSpec::toUnit(double value) const {
  const double x = log ? std::log(value / lo) / std::log(hi / lo) : (value - lo) / (hi - lo);
  return std::clamp(x, 0.0, 1.0);
}

std::string ParameterSpec::label() const {
  const auto slash = pointer.find_last_of('/');
  return slash == std::string::npos ? pointer : pointer.substr(slash + 1);
}

ParameterSpec parseParameterSpec(const std::string& argument) {
  const auto eq = argument.rfind('=');
  if (eq == std::string::npos || eq == 0)
    throw ArgumentError("--fit '" + argument + "': expected PATH=LO:HI[:log], e.g. /tools/0/fem/E_Pa=2e9:8e9:log");
  ParameterSpec spec;
  spec.argument = argument;
  spec.pointer = argument.substr(0, eq);
  if (spec.pointer.front() != '/') throw ArgumentError("--fit '" + argument + "': PATH must be a JSON pointer starting with '/'");
  const std::vector<std::string> parts = split(argument.substr(eq + 1), ':');
  if (parts.size() < 2 || parts.size() > 3)
    throw ArgumentError("--fit '" + argument + "': expected LO:HI or LO:HI:log after '='");
  spec.lo = parseNumber(parts[0], argument, "LO");
  spec.hi = parseNumber(parts[1], argument, "HI");
  if (parts.size() == 3) {
    if (parts[2] != "log") throw ArgumentError("--fit '" + argument + "': the third field must be 'log' (got '" + parts[2] + "')");
    spec.log = true;
  }
  if (!(spec.lo < spec.hi)) throw ArgumentError("--fit '" + argument + "': LO must be smaller than HI");
  if (spec.log && !(spec.lo > 0)) throw ArgumentError("--fit '" + argument + "': a log parameter needs LO > 0");
  return spec;
}

void validateParameters(const nlohmann::ordered_json& study_json, const std::string& origin, const std::vector<ParameterSpec>& specs) {
  std::set<std::string> seen;
  for (const ParameterSpec& spec : specs) {
    const auto pointer = pointerOf(spec);
    if (!seen.insert(pointer.to_string()).second) throw ArgumentError(quoted(spec) + ": " + spec.pointer + " is fitted twice");
    if (!study_json.contains(pointer)) throw ArgumentError(quoted(spec) + ": " + origin + " has no value at " + spec.pointer);
    const auto& node = study_json.at(pointer);
    if (!node.is_number())
      throw ArgumentError(quoted(spec) + ": " + origin + ": " + spec.pointer + " is not a number (it is " + node.type_name() + ")");
    checkLoadable(study_json, origin, spec, spec.lo, "lower");
    checkLoadable(study_json, origin, spec, spec.hi, "upper");
  }
}

nlohmann::ordered_json withValues(const nlohmann::ordered_json& study_json, const std::vector<ParameterSpec>& specs,
                                  const std::vector<double>& values) {
  nlohmann::ordered_json copy = study_json;
  for (std::size_t i = 0; i < specs.size(); ++i) copy[nlohmann::ordered_json::json_pointer(specs[i].pointer)] = values[i];
  return copy;
}

std::vector<double> currentValues(const nlohmann::ordered_json& study_json, const std::vector<ParameterSpec>& specs) {
  std::vector<double> values;
  for (const auto& spec : specs) values.push_back(study_json.at(nlohmann::ordered_json::json_pointer(spec.pointer)).get<double>());
  return values;
}

}  // namespace demfem::campaign

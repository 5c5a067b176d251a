// demfem campaign: the study numbers a calibration varies, named by JSON pointer into the study
// file (docs/calibration.md).
//
// Contract
// - A parameter is any number of a study file, in the file's own unit (the key name says it:
//   /tools/0/fem/E_Pa, /tools/0/fem/alpha_s, /soil/interactions/5/static_friction).
// - Command-line form `PATH=LO:HI[:log]`: LO < HI, both finite; `log` (LO > 0) makes the optimiser
//   work on log(value), for quantities spanning decades.
// - validateParameters(): the pointer exists in the study JSON and is a number, and the study with
//   the value set to LO and to HI still passes the study loader (so the bounds lie inside the
//   study's valid range). Every problem throws ArgumentError naming the argument.
// - Optimiser coordinates: each parameter maps to x in [0, 1] (linear, or linear in log for `log`),
//   toValue()/toUnit() convert.
#pragma once

#include <nlohmann/json.hpp>

#include <stdexcept>
#include <string>
#include <vector>

namespace demfem::campaign {

// Bad command-line or API argument; the message names the argument as given (e.g. "--fit
// '/tools/0/fem/E_Pa=1:2': ...").
class ArgumentError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

struct ParameterSpec {
  std::string pointer;  // JSON pointer into the study file, e.g. "/tools/0/fem/E_Pa"
  double lo = 0, hi = 0;  // bounds in the file's unit
  bool log = false;
  std::string argument;  // as given by the user (for messages); may be empty for built-in specs

  double toValue(double unit) const;  // x in [0, 1] -> value
  double toUnit(double value) const;  // value -> x (clamped to [0, 1])
  // The short name used in reports: the pointer's last token with its index path, e.g. "E_Pa".
  std::string label() const;
};

// Parses `PATH=LO:HI[:log]`. Throws ArgumentError naming `argument`.
ParameterSpec parseParameterSpec(const std::string& argument);

// Checks every spec against `study_json` (see contract). `origin` is the study file (relative file
// names inside the study resolve against its directory). Throws ArgumentError; also for two specs
// naming the same pointer.
void validateParameters(const nlohmann::ordered_json& study_json, const std::string& origin,
                        const std::vector<ParameterSpec>& specs);

// A copy of `study_json` with specs[i] set to values[i] (file units). Pre: sizes equal, pointers
// validated.
nlohmann::ordered_json withValues(const nlohmann::ordered_json& study_json, const std::vector<ParameterSpec>& specs,
                                  const std::vector<double>& values);

// The current values of the specs in `study_json`. Pre: pointers validated.
std::vector<double> currentValues(const nlohmann::ordered_json& study_json, const std::vector<ParameterSpec>& specs);

}  // namespace demfem::campaign

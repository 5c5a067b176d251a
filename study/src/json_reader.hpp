// Private to the study library: typed, validating reads of a JSON object that collect every problem
// as an Issue (JSON pointer + message) instead of stopping at the first one.
//
// The unit of a number is part of its key (`depth_mm`, `E_Pa`, `velocity_mm_s`); unitOf() and
// toSi() read it from the key's suffix, so every conversion to SI happens in one place.
#pragma once

#include "demfem/study/study.hpp"

#include <nlohmann/json.hpp>

#include <optional>
#include <set>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace demfem::study::detail {

// Display unit of a key, from its suffix ("mm/s" for `velocity_mm_s`, "-" for a plain ratio such as
// `nu`); empty for keys that are not physical quantities.
std::string unitOf(std::string_view key);

// Factor from the key's file unit to SI (1e-3 for `_mm`, pi/180 for `_deg`, ...).
double siFactorOf(std::string_view key);

// Numbers in messages and descriptions: the fewest significant digits (at most 12) that reproduce
// the value; scientific below 1e-4 and from 1e5 on, with a bare exponent (-4.06e9, 7.93e-7, 0.00055,
// 2600).
std::string formatNumber(double value);

// At most `bytes` bytes of `text`, cut at a character boundary (never inside a UTF-8 sequence).
std::string utf8Prefix(std::string_view text, std::size_t bytes);

// JSON pointer escaping of one reference token (RFC 6901: '~' -> "~0", '/' -> "~1").
std::string pointerToken(std::string_view key);

// Allowed interval of a number, in the file's unit. Each end may be open or closed.
struct Limits {
  std::optional<double> low, high;
  bool low_open = false, high_open = false;
  bool contains(double v) const;
  std::string describe() const;  // "> 0", ">= 0 and <= 1"; empty if unbounded
};
Limits positive();
Limits nonNegative();
Limits openInterval(double low, double high);
Limits closedInterval(double low, double high);
Limits leftOpen(double low, double high);  // (low, high]

class IssueList {
 public:
  void add(std::string path, std::string message) { items_.push_back({std::move(path), std::move(message)}); }
  const std::vector<Issue>& items() const { return items_; }
  bool empty() const { return items_.empty(); }

 private:
  std::vector<Issue> items_;
};

enum class Need { Required, Optional };

// Reads the members of one JSON object. A missing or non-object value makes a reader whose reads
// all return nothing (the problem is reported once, by whoever found it). finish() reports every
// member that no read, known() or forbid() call asked for, as an unknown key.
class ObjectReader {
 public:
  ObjectReader(const nlohmann::json* value, std::string path, IssueList& issues);

  bool valid() const { return value_ != nullptr; }
  const nlohmann::json* value() const { return value_; }
  const std::string& path() const { return path_; }
  std::string pathOf(std::string_view key) const { return path_ + "/" + pointerToken(key); }
  bool has(std::string_view key) const;

  // A number in the key's file unit, checked against `limits` (given in the same unit).
  std::optional<double> number(std::string_view key, Limits limits, Need need);
  // The same, converted to SI by the key's unit suffix.
  std::optional<double> quantity(std::string_view key, Limits limits, Need need);
  std::optional<long long> integer(std::string_view key, long long minimum, long long maximum, Need need);
  std::optional<std::string> string(std::string_view key, Need need);
  std::optional<bool> boolean(std::string_view key, Need need);
  // One of `choices` (file spelling -> value).
  template <class E>
  std::optional<E> choice(std::string_view key, const std::vector<std::pair<std::string, E>>& choices, Need need);
  // A nested object; if it is missing (and required) or not an object, the reader is invalid.
  ObjectReader object(std::string_view key, Need need);
  // A nested array of at least `min_size` elements; nullptr if missing or invalid.
  const nlohmann::json* array(std::string_view key, Need need, std::size_t min_size = 0);

  // The member `key` as it is (marked as read), nullptr if absent; for values of their own shape.
  const nlohmann::json* raw(std::string_view key);
  // A problem with the member `key`.
  void report(std::string_view key, std::string message) { issues_.add(pathOf(key), std::move(message)); }
  // Marks `key` as recognised without reading it.
  void known(std::string_view key) { seen_.insert(std::string(key)); }
  // `key` must not appear: it does not apply (`reason` says why, e.g. "the tool of a dem-only
  // study is rigid").
  void forbid(std::string_view key, const std::string& reason);

  // Reports unknown keys (with the nearest known key as a suggestion).
  void finish();

 private:
  const nlohmann::json* member(std::string_view key, Need need, const char* expected);
  void missing(std::string_view key, const char* expected);
  void wrongType(std::string_view key, const nlohmann::json& got, const char* expected);

  const nlohmann::json* value_;
  std::string path_;
  IssueList& issues_;
  std::set<std::string> seen_;
};

// Short description of a JSON value for messages: `string "abc"`, `array`, `number 3`.
std::string describeValue(const nlohmann::json& value);

template <class E>
std::optional<E> ObjectReader::choice(std::string_view key, const std::vector<std::pair<std::string, E>>& choices,
                                      Need need) {
  const std::optional<std::string> text = string(key, need);
  if (!text) return std::nullopt;
  for (const auto& [name, value] : choices)
    if (name == *text) return value;
  std::string list;
  for (const auto& [name, value] : choices) list += (list.empty() ? "\"" : ", \"") + name + "\"";
  issues_.add(pathOf(key), "must be one of " + list + "; got \"" + *text + "\"");
  return std::nullopt;
}

}  // namespace demfem::study::detail

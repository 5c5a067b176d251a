#include "json_reader.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <numbers>

namespace demfem::study::detail {

namespace {

struct UnitSuffix {
  std::string_view suffix;
  std::string_view unit;
  double to_si;
};

// Longest suffixes first so that `_mm_s` wins over `_s` and `_mm2` over `_mm`.
constexpr std::array<UnitSuffix, 13> kUnitSuffixes{{
    {"_Nm_per_rad", "N m/rad", 1.0},
    {"_mm_s", "mm/s", 1e-3},
    {"_kg_m3", "kg/m^3", 1.0},
    {"_J_m3", "J/m^3", 1.0},
    {"_per_s", "1/s", 1.0},
    {"_m_s", "m/s", 1.0},
    {"_mm2", "mm^2", 1e-6},
    {"_deg", "deg", std::numbers::pi / 180.0},
    {"_mm", "mm", 1e-3},
    {"_Pa", "Pa", 1.0},
    {"_kg", "kg", 1.0},
    {"_J", "J", 1.0},
    {"_s", "s", 1.0},
}};

const UnitSuffix* suffixOf(std::string_view key) {
  for (const auto& s : kUnitSuffixes)
    if (key.size() > s.suffix.size() && key.ends_with(s.suffix)) return &s;
  return nullptr;
}

std::size_t editDistance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = up;
    }
  }
  return row[b.size()];
}

const char* typeName(const nlohmann::json& v) {
  if (v.is_null()) return "null";
  if (v.is_boolean()) return "boolean";
  if (v.is_number()) return "number";
  if (v.is_string()) return "string";
  if (v.is_array()) return "array";
  return "object";
}

}  // namespace

std::string unitOf(std::string_view key) {
  const UnitSuffix* s = suffixOf(key);
  return s ? std::string(s->unit) : std::string("-");
}

double siFactorOf(std::string_view key) {
  const UnitSuffix* s = suffixOf(key);
  return s ? s->to_si : 1.0;
}

std::string formatNumber(double value) {
  if (value == 0) return "0";
  if (!std::isfinite(value)) return std::isnan(value) ? "nan" : (value > 0 ? "inf" : "-inf");
  // Fewest significant digits (at most 12) that reproduce the value.
  char buffer[64];
  int digits = 12;
  for (int p = 1; p < 12; ++p) {
    std::snprintf(buffer, sizeof buffer, "%.*e", p - 1, value);
    if (std::strtod(buffer, nullptr) == value) {
      digits = p;
      break;
    }
  }
  const auto trimZeros = [](std::string text) {
    if (text.find('.') == std::string::npos) return text;
    text.erase(text.find_last_not_of('0') + 1);
    if (text.back() == '.') text.pop_back();
    return text;
  };
  std::snprintf(buffer, sizeof buffer, "%.*e", digits - 1, value);
  const std::string scientific(buffer);
  const std::size_t e = scientific.find('e');
  const int exponent = std::stoi(scientific.substr(e + 1));
  const double magnitude = std::abs(value);
  if (magnitude >= 1e5 || magnitude < 1e-4) return trimZeros(scientific.substr(0, e)) + "e" + std::to_string(exponent);
  std::snprintf(buffer, sizeof buffer, "%.*f", std::max(0, digits - 1 - exponent), value);
  return trimZeros(buffer);
}

namespace {

// Length of the well-formed UTF-8 sequence at the start of `text` (RFC 3629: no overlong forms,
// no surrogates, at most U+10FFFF), or 0.
std::size_t utf8SequenceLength(std::string_view text) {
  const auto byte = [&](std::size_t i) { return static_cast<unsigned char>(text[i]); };
  const unsigned char lead = byte(0);
  if (lead < 0x80) return 1;
  std::size_t n = 0;
  unsigned char low = 0x80, high = 0xbf;  // allowed range of the second byte
  if (lead >= 0xc2 && lead <= 0xdf) n = 2;
  else if (lead >= 0xe0 && lead <= 0xef) {
    n = 3;
    if (lead == 0xe0) low = 0xa0;
    if (lead == 0xed) high = 0x9f;
  } else if (lead >= 0xf0 && lead <= 0xf4) {
    n = 4;
    if (lead == 0xf0) low = 0x90;
    if (lead == 0xf4) high = 0x8f;
  } else {
    return 0;
  }
  if (text.size() < n || byte(1) < low || byte(1) > high) return 0;
  for (std::size_t i = 2; i < n; ++i)
    if (byte(i) < 0x80 || byte(i) > 0xbf) return 0;
  return n;
}

}  // namespace

}  // namespace demfem::study::detail

namespace demfem::study {

std::string validUtf8(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  while (!text.empty()) {
    const std::size_t n = detail::utf8SequenceLength(text);
    if (n == 0) {
      char escaped[8];
      std::snprintf(escaped, sizeof escaped, "\\x%02X", static_cast<unsigned char>(text[0]));
      out += escaped;
      text.remove_prefix(1);
    } else {
      out += text.substr(0, n);
      text.remove_prefix(n);
    }
  }
  return out;
}

}  // namespace demfem::study

namespace demfem::study::detail {

std::string utf8Prefix(std::string_view text, std::size_t bytes) {
  std::size_t end = 0;
  while (end < text.size()) {
    const std::size_t n = std::max<std::size_t>(1, utf8SequenceLength(text.substr(end)));
    if (end + n > bytes) break;
    end += n;
  }
  return std::string(text.substr(0, end));
}

std::string pointerToken(std::string_view key) {
  std::string out;
  for (char c : key) {
    if (c == '~')
      out += "~0";
    else if (c == '/')
      out += "~1";
    else
      out += c;
  }
  return out;
}

std::string describeValue(const nlohmann::json& value) {
  if (value.is_string()) {
    std::string text = value.get<std::string>();
    if (text.size() > 40) text = utf8Prefix(text, 37) + "...";
    return "string \"" + text + "\"";
  }
  if (value.is_number()) return "number " + formatNumber(value.get<double>());
  if (value.is_boolean()) return value.get<bool>() ? "true" : "false";
  return typeName(value);
}

bool Limits::contains(double v) const {
  if (low && (low_open ? !(v > *low) : !(v >= *low))) return false;
  if (high && (high_open ? !(v < *high) : !(v <= *high))) return false;
  return true;
}

std::string Limits::describe() const {
  std::string text;
  if (low) text = std::string(low_open ? "> " : ">= ") + formatNumber(*low);
  if (high) text += (text.empty() ? "" : " and ") + std::string(high_open ? "< " : "<= ") + formatNumber(*high);
  return text;
}

Limits positive() { return {0.0, std::nullopt, true, false}; }
Limits nonNegative() { return {0.0, std::nullopt, false, false}; }
Limits openInterval(double low, double high) { return {low, high, true, true}; }
Limits closedInterval(double low, double high) { return {low, high, false, false}; }
Limits leftOpen(double low, double high) { return {low, high, true, false}; }

ObjectReader::ObjectReader(const nlohmann::json* value, std::string path, IssueList& issues)
    : value_(value), path_(std::move(path)), issues_(issues) {
  if (value_ && !value_->is_object()) {
    issues_.add(path_, std::string("must be a JSON object, got ") + describeValue(*value_));
    value_ = nullptr;
  }
}

bool ObjectReader::has(std::string_view key) const { return value_ && value_->contains(key); }

void ObjectReader::missing(std::string_view key, const char* expected) {
  issues_.add(pathOf(key), std::string("missing required key (") + expected + ")");
}

void ObjectReader::wrongType(std::string_view key, const nlohmann::json& got, const char* expected) {
  issues_.add(pathOf(key), std::string("must be ") + expected + ", got " + describeValue(got));
}

const nlohmann::json* ObjectReader::member(std::string_view key, Need need, const char* expected) {
  seen_.insert(std::string(key));
  if (!value_) return nullptr;
  const auto it = value_->find(key);
  if (it == value_->end()) {
    if (need == Need::Required) missing(key, expected);
    return nullptr;
  }
  return &*it;
}

std::optional<double> ObjectReader::number(std::string_view key, Limits limits, Need need) {
  const std::string unit = unitOf(key);
  const std::string range = limits.describe();
  const std::string expected =
      "a number" + (unit == "-" ? std::string() : " in " + unit) + (range.empty() ? "" : ", " + range);
  const nlohmann::json* v = member(key, need, expected.c_str());
  if (!v) return std::nullopt;
  if (!v->is_number()) {
    wrongType(key, *v, expected.c_str());
    return std::nullopt;
  }
  const double x = v->get<double>();
  if (!limits.contains(x)) {
    issues_.add(pathOf(key), "must be " + range + ", got " + formatNumber(x));
    return std::nullopt;
  }
  return x;
}

std::optional<double> ObjectReader::quantity(std::string_view key, Limits limits, Need need) {
  const std::optional<double> x = number(key, limits, need);
  if (!x) return std::nullopt;
  const double factor = siFactorOf(key);
  // Dividing by 1000 (exact) rather than multiplying by 1e-3 (inexact) gives the double nearest the
  // true value for whole numbers of mm: 18 mm -> 0.018 m, not 0.018000000000000002.
  if (factor == 1e-3) return *x / 1e3;
  if (factor == 1e-6) return *x / 1e6;
  return *x * factor;
}

std::optional<long long> ObjectReader::integer(std::string_view key, long long minimum, long long maximum, Need need) {
  const std::string expected = "an integer >= " + std::to_string(minimum) + " and <= " + std::to_string(maximum);
  const nlohmann::json* v = member(key, need, expected.c_str());
  if (!v) return std::nullopt;
  if (!v->is_number_integer()) {
    wrongType(key, *v, expected.c_str());
    return std::nullopt;
  }
  const bool above = v->is_number_unsigned() ? v->get<unsigned long long>() > static_cast<unsigned long long>(maximum)
                                             : v->get<long long>() > maximum;
  if (above || v->get<long long>() < minimum) {
    issues_.add(pathOf(key), "must be " + expected.substr(std::string("an integer ").size()) + ", got " + v->dump());
    return std::nullopt;
  }
  return v->get<long long>();
}

std::optional<std::string> ObjectReader::string(std::string_view key, Need need) {
  const nlohmann::json* v = member(key, need, "a non-empty string");
  if (!v) return std::nullopt;
  if (!v->is_string() || v->get<std::string>().empty()) {
    wrongType(key, *v, "a non-empty string");
    return std::nullopt;
  }
  return v->get<std::string>();
}

std::optional<bool> ObjectReader::boolean(std::string_view key, Need need) {
  const nlohmann::json* v = member(key, need, "true or false");
  if (!v) return std::nullopt;
  if (!v->is_boolean()) {
    wrongType(key, *v, "true or false");
    return std::nullopt;
  }
  return v->get<bool>();
}

ObjectReader ObjectReader::object(std::string_view key, Need need) {
  return ObjectReader(member(key, need, "an object"), pathOf(key), issues_);
}

const nlohmann::json* ObjectReader::array(std::string_view key, Need need, std::size_t min_size) {
  const std::string expected =
      min_size > 0 ? "an array of at least " + std::to_string(min_size) + " element(s)" : std::string("an array");
  const nlohmann::json* v = member(key, need, expected.c_str());
  if (!v) return nullptr;
  if (!v->is_array() || v->size() < min_size) {
    wrongType(key, *v, expected.c_str());
    return nullptr;
  }
  return v;
}

const nlohmann::json* ObjectReader::raw(std::string_view key) { return member(key, Need::Optional, ""); }

void ObjectReader::forbid(std::string_view key, const std::string& reason) {
  seen_.insert(std::string(key));
  if (has(key)) issues_.add(pathOf(key), "does not apply: " + reason + "; remove it");
}

void ObjectReader::finish() {
  if (!value_) return;
  for (const auto& [key, v] : value_->items()) {
    if (seen_.count(key)) continue;
    std::string message = "unknown key";
    std::size_t best = 3;  // suggest only close misspellings
    std::string suggestion;
    for (const std::string& candidate : seen_) {
      const std::size_t d = editDistance(key, candidate);
      if (d < best) {
        best = d;
        suggestion = candidate;
      }
    }
    if (!suggestion.empty()) message += " (did you mean \"" + suggestion + "\"?)";
    issues_.add(pathOf(key), message);
  }
}

}  // namespace demfem::study::detail

// Private to the study library: the declarative key table of the study file. Every leaf key is one
// row (name, the Study field it fills, unit from its suffix, range, required or default, when it
// applies, one doc line); reading (load.cpp), writing (serialize.cpp, and through it describe()
// and validate()) and the key reference of docs/study-file.md (keyReference()) are generated from
// these rows. Cross-field rules are in validate.cpp.
#pragma once

#include "demfem/study/study.hpp"

#include "enum_names.hpp"
#include "json_reader.hpp"

#include <nlohmann/json.hpp>

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <string_view>
#include <variant>
#include <vector>

namespace demfem::study::detail {

// What decides whether a key applies: the parts of the study around it. Values not known yet (an
// invalid enumeration string in the file) are nullopt; keys that depend on them are read unjudged.
struct KeyContext {
  StudyKind kind = StudyKind::Coupled;
  std::optional<NormalModel> normal;
  std::optional<CohesionModel> cohesion;
  std::optional<RollingModel> rolling;
  std::optional<GeometryKind> geometry;  // of the tool whose keys are read
  bool deformable = true;                // of that tool
  bool explicit_dem_step = false;        // dem.dt_s given
  bool identity_form = false;            // writing identityJson(): see Key::identity_omits_default
};

// Whether a key applies in a context; `reason` says why not ("the tool is rigid ...").
struct Applies {
  enum State { Yes, No, Unknown } state = Yes;
  std::string reason;
};

// When a key applies: the test, and the same rule in words for the docs ("" = always).
struct AppliesWhen {
  std::function<Applies(const KeyContext&)> test;
  std::string doc;
};

// An enumeration field, by its file spelling.
template <class T>
struct ChoiceField {
  std::vector<std::string> names;
  std::function<std::string(const T&)> get;
  std::function<void(T&, const std::string&)> set;
};

// A field read and written by code of its own (a string-or-array, a pair of names).
template <class T>
struct CustomField {
  std::string type_doc;
  std::function<bool(ObjectReader&, std::string_view key, T&, Need)> read;  // false: invalid
  std::function<void(nlohmann::ordered_json&, std::string_view key, const T&)> write;
};

// A file name, resolved against the study file's directory on reading.
template <class T>
struct FileField {
  std::filesystem::path T::*member;
};

template <class T>
using Field = std::variant<double T::*, std::optional<double> T::*, int T::*, std::uint64_t T::*, bool T::*,
                           std::string T::*, std::filesystem::path T::*, FileField<T>, ChoiceField<T>, CustomField<T>>;

struct IntegerRange {
  long long min = 0, max = 0;
};

template <class T>
struct Key {
  std::string_view name;
  Field<T> field;
  Need need = Need::Required;
  Limits range{};                 // numbers, in the key's file unit
  IntegerRange integers{};        // integers
  AppliesWhen applies{};          // empty test: always
  std::string default_doc{};      // optional keys whose default is not the struct's initial value
  std::string doc{};              // one line for the docs
  // A key added after results were kept, whose default gives the numbers of the studies written
  // before it: identityJson() leaves it out at its default, so those studies stay the same case.
  bool identity_omits_default = false;
};

// One object of the file: where it is (dotted, `[]` for array entries) and its keys in file order.
template <class T>
struct Section {
  std::string path;
  std::vector<Key<T>> keys;
};

template <class T, class E>
ChoiceField<T> choice(E T::*member, const NameTable<E>& table) {
  ChoiceField<T> field;
  for (const auto& [name, value] : table) field.names.push_back(name);
  field.get = [member, &table](const T& object) { return nameOf(table, object.*member); };
  field.set = [member, &table](T& object, const std::string& name) {
    for (const auto& [word, value] : table)
      if (word == name) object.*member = value;
  };
  return field;
}

// The sections, in file order. `tools[]` keys read with the tool's KeyContext.
const Section<Study>& topSection();
const Section<Soil>& binSection();
const Section<Soil>& soilSection();           // fill_height_mm
const Section<Soil>& particlesSection();
const Section<DemMaterial>& materialSection();
const Section<ContactModel>& contactSection();
const Section<Layer>& layerSection();
const Section<Interaction>& interactionSection();
const Section<Soil>& depositionSection();
const Section<Tool>& toolSection();           // name, dem_material
const Section<ToolGeometry>& geometrySection();
const Section<ToolFem>& toolFemSection();
const Section<ToolConstraints>& constraintsSection();
const Section<ToolSensors>& sensorsSection();
const Section<ToolMotion>& motionSection();
const Section<WeightDrop>& weightDropSection();
const Section<FemSettings>& femSection();
const Section<DemSettings>& demSection();
const Section<CouplingSettings>& couplingSection();
const Section<OutputSettings>& outputSection();

// Reads every key of `section` from `o` into `target`: the applicable ones with their type, range
// and need, the others forbidden with their reason. `base_dir` resolves file names.
template <class T>
void readKeys(ObjectReader& o, const Section<T>& section, T& target, const KeyContext& context,
              const std::filesystem::path& base_dir);

// Writes every applicable key of `section` from `source`, in the key's file unit (empty strings
// and absent optionals are left out).
template <class T>
void writeKeys(nlohmann::ordered_json& out, const Section<T>& section, const T& source, const KeyContext& context);

// The Markdown key table of docs/study-file.md: one row per key of every section, in file order.
std::string keyReferenceTable();

// SI value -> the unit of `key`, rounded to 12 significant digits (conversion noise only).
double fileValue(std::string_view key, double si);

}  // namespace demfem::study::detail

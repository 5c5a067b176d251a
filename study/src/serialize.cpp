// Study -> file form (toJson), its "path = value unit" listing (describe) and the soil hash.
#include "demfem/study/study.hpp"

#include "enum_names.hpp"
#include "json_reader.hpp"
#include "schema.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <sstream>
#include <stdexcept>

namespace demfem::study {

namespace {

using detail::KeyContext;
using detail::nameOf;
using detail::writeKeys;
using nlohmann::ordered_json;

// What decides which keys a study's file form has.
KeyContext contextOf(const Study& study) {
  KeyContext context;
  context.kind = study.kind;
  context.normal = study.soil.contact.normal;
  context.cohesion = study.soil.contact.cohesion;
  context.rolling = study.soil.contact.rolling;
  context.explicit_dem_step = study.dem.dt_s.has_value();
  return context;
}

template <class T>
ordered_json entriesJson(const std::vector<T>& entries, const detail::Section<T>& section, const KeyContext& context) {
  ordered_json out = ordered_json::array();
  for (const T& entry : entries) {
    ordered_json object = ordered_json::object();
    writeKeys(object, section, entry, context);
    out.push_back(object);
  }
  return out;
}

ordered_json soilJson(const Soil& soil, const KeyContext& context) {
  ordered_json out;
  writeKeys(out["bin"], detail::binSection(), soil, context);
  writeKeys(out, detail::soilSection(), soil, context);
  writeKeys(out["particles"], detail::particlesSection(), soil, context);
  out["materials"] = entriesJson(soil.materials, detail::materialSection(), context);
  writeKeys(out["contact"], detail::contactSection(), soil.contact, context);
  out["layers"] = entriesJson(soil.layers, detail::layerSection(), context);
  out["interactions"] = entriesJson(soil.interactions, detail::interactionSection(), context);
  writeKeys(out["deposition"], detail::depositionSection(), soil, context);
  return out;
}

ordered_json toolJson(const Tool& tool, KeyContext context) {
  context.geometry = tool.geometry.kind;
  context.deformable = tool.fem.deformable;
  ordered_json out;
  writeKeys(out, detail::toolSection(), tool, context);
  writeKeys(out["geometry"], detail::geometrySection(), tool.geometry, context);
  if (tool.fem.deformable || context.kind == StudyKind::DemOnly)
    writeKeys(out["fem"], detail::toolFemSection(), tool.fem, context);
  if (tool.geometry.kind != GeometryKind::Cone)
    writeKeys(out["constraints"], detail::constraintsSection(), tool.constraints, context);
  if (tool.fem.deformable) writeKeys(out["sensors"], detail::sensorsSection(), tool.sensors, context);
  if (hasSoil(context.kind)) writeKeys(out["motion"], detail::motionSection(), tool.motion, context);
  return out;
}

ordered_json demJson(const Study& study, const KeyContext& context) {
  ordered_json out;
  writeKeys(out, detail::demSection(), study.dem, context);
  return out;
}

ordered_json studyJson(const Study& study, const KeyContext& context) {
  ordered_json out;
  writeKeys(out, detail::topSection(), study, context);
  if (hasSoil(study.kind)) out["soil"] = soilJson(study.soil, context);
  out["tools"] = ordered_json::array();
  for (const Tool& tool : study.tools) out["tools"].push_back(toolJson(tool, context));
  if (study.weight_drop) writeKeys(out["weight_drop"], detail::weightDropSection(), *study.weight_drop, context);
  writeKeys(out["fem"], detail::femSection(), study.fem, context);
  if (hasSoil(study.kind)) {
    out["dem"] = demJson(study, context);
    writeKeys(out["coupling"], detail::couplingSection(), study.coupling, context);
  }
  writeKeys(out["output"], detail::outputSection(), study.output, context);
  return out;
}

KeyContext identityContextOf(const Study& study) {
  KeyContext context = contextOf(study);
  context.identity_form = true;
  return context;
}

void describeInto(std::ostringstream& out, const std::string& path, const std::string& key, const ordered_json& v) {
  if (v.is_object()) {
    for (const auto& [k, child] : v.items()) describeInto(out, path + "/" + detail::pointerToken(k), k, child);
    return;
  }
  if (v.is_array() && !v.empty() && v.front().is_structured()) {
    for (std::size_t i = 0; i < v.size(); ++i) describeInto(out, path + "/" + std::to_string(i), key, v[i]);
    return;
  }
  out << path << " = ";
  if (v.is_string()) {
    out << v.get<std::string>();
  } else if (v.is_number_float()) {
    out << detail::formatNumber(v.get<double>());
    const std::string unit = detail::unitOf(key);
    if (unit != "-") out << ' ' << unit;
  } else {
    out << v.dump();
  }
  out << '\n';
}

}  // namespace

std::uint64_t fnv1a64(std::string_view bytes) {
  std::uint64_t hash = 14695981039346656037ull;
  for (unsigned char c : bytes) {
    hash ^= c;
    hash *= 1099511628211ull;
  }
  return hash;
}

ordered_json toJson(const Study& study) { return studyJson(study, contextOf(study)); }

ordered_json identityJson(const Study& study) { return studyJson(study, identityContextOf(study)); }

std::string describe(const Study& study) {
  ordered_json doc = toJson(study);
  doc.erase("notes");  // free text, not a value
  std::ostringstream out;
  describeInto(out, "", "", doc);
  return out.str();
}

std::string soilHash(const Study& study) {
  if (!hasSoil(study.kind))
    throw std::invalid_argument("soilHash: a " + nameOf(detail::kStudyKinds, study.kind) + " study has no soil");
  const Soil& soil = study.soil;
  // Only what the deposition sees: particle (layer) materials and the bin, not the tools.
  std::set<std::string> used{soil.bin_material};
  for (const Layer& l : soil.layers) used.insert(l.material);
  nlohmann::json canonical;  // std::map objects: keys sorted
  const KeyContext context = identityContextOf(study);
  canonical["soil"] = nlohmann::json::parse(soilJson(soil, context).dump());
  nlohmann::json& materials = canonical["soil"]["materials"];
  nlohmann::json soil_materials = nlohmann::json::array();
  for (const auto& m : materials)
    if (used.count(m["name"].get<std::string>())) soil_materials.push_back(m);
  std::sort(soil_materials.begin(), soil_materials.end(),
            [](const auto& a, const auto& b) { return a["name"] < b["name"]; });
  materials = soil_materials;
  // The interaction table as a set: entries sorted by their (sorted) pair, tool pairs dropped.
  nlohmann::json& interactions = canonical["soil"]["interactions"];
  nlohmann::json kept = nlohmann::json::array();
  for (auto entry : interactions) {
    auto& pair = entry["materials"];
    if (!used.count(pair[0].get<std::string>()) || !used.count(pair[1].get<std::string>())) continue;
    if (pair[1] < pair[0]) std::swap(pair[0], pair[1]);
    kept.push_back(entry);
  }
  std::sort(kept.begin(), kept.end(), [](const auto& a, const auto& b) { return a["materials"] < b["materials"]; });
  interactions = kept;
  nlohmann::json dem = nlohmann::json::parse(demJson(study, context).dump());
  dem.erase("seed");     // the run's seed; the deposition has soil.deposition.seed
  dem.erase("threads");  // one soil for every core count
  dem.erase("backend");  // the run's backend; the deposition's is soil.deposition.backend
  canonical["dem"] = dem;
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx",
                static_cast<unsigned long long>(fnv1a64("demfem-soil-v5\n" + canonical.dump())));
  return hex;
}

}  // namespace demfem::study

// Study -> file form (toJson), its "path = value unit" listing (describe) and the soil hash.
#include "demfem/study/study.hpp"

#include "enum_names.hpp"
#include "json_reader.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <set>
#include <sstream>
#include <stdexcept>

namespace demfem::study {

namespace {

using detail::nameOf;
using nlohmann::ordered_json;

// SI value -> the unit of `key`, rounded to 12 significant digits so that 0.018 m prints as 18 mm
// rather than 18.000000000000004 (conversion noise only; study values carry far fewer digits).
double fileValue(const char* key, double si) {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%.12g", si / detail::siFactorOf(key));
  return std::strtod(buffer, nullptr);
}

// Appends `key: value` in the key's file unit.
void put(ordered_json& object, const char* key, double si) { object[key] = fileValue(key, si); }

ordered_json soilJson(const Soil& soil) {
  ordered_json out;
  ordered_json& bin = out["bin"];
  put(bin, "length_mm", soil.bin_length_m);
  put(bin, "width_mm", soil.bin_width_m);
  bin["material"] = soil.bin_material;
  put(out, "fill_height_mm", soil.fill_height_m);
  put(out["particles"], "diameter_min_mm", soil.diameter_min_m);
  put(out["particles"], "diameter_max_mm", soil.diameter_max_m);
  out["materials"] = ordered_json::array();
  for (const DemMaterial& m : soil.materials) {
    ordered_json entry;
    entry["name"] = m.name;
    put(entry, "density_kg_m3", m.density_kg_m3);
    put(entry, "E_Pa", m.youngs_Pa);
    put(entry, "nu", m.poisson);
    put(entry, "yield_Pa", m.yield_Pa);
    out["materials"].push_back(entry);
  }
  const ContactModel& c = soil.contact;
  ordered_json& contact = out["contact"];
  contact["normal"] = nameOf(detail::kNormalModels, c.normal);
  contact["cohesion"] = nameOf(detail::kCohesionModels, c.cohesion);
  contact["rolling"] = nameOf(detail::kRollingModels, c.rolling);
  contact["tangential_history"] = c.tangential_history;
  if (c.normal == NormalModel::EdemHysteretic) {
    put(contact, "stiffness_factor", c.stiffness_factor);
    put(contact, "damping_factor", c.damping_factor);
  } else {
    put(contact, "characteristic_velocity_m_s", c.characteristic_velocity_m_s);
  }
  if (c.normal == NormalModel::HookeHysteresis) {
    put(contact, "coefficient_max_elastic_stiffness", c.coefficient_max_elastic_stiffness);
    put(contact, "coefficient_plasticity_depth", c.coefficient_plasticity_depth);
    put(contact, "coefficient_adhesion_stiffness", c.coefficient_adhesion_stiffness);
  }
  out["layers"] = ordered_json::array();
  for (const Layer& l : soil.layers) {
    ordered_json entry;
    entry["material"] = l.material;
    put(entry, "top_depth_mm", l.top_depth_m);
    put(entry, "bottom_depth_mm", l.bottom_depth_m);
    out["layers"].push_back(entry);
  }
  out["interactions"] = ordered_json::array();
  for (const Interaction& i : soil.interactions) {
    ordered_json entry;
    entry["materials"] = {i.a, i.b};
    put(entry, "restitution", i.restitution);
    put(entry, "static_friction", i.static_friction);
    if (c.rolling != RollingModel::None) put(entry, "rolling_friction", i.rolling_friction);
    if (c.cohesion != CohesionModel::None) put(entry, "cohesion_J_m3", i.cohesion_J_m3);
    out["interactions"].push_back(entry);
  }
  out["deposition"]["seed"] = soil.deposition_seed;
  put(out["deposition"], "settle_kinetic_energy_J", soil.settle_kinetic_energy_J);
  out["deposition"]["backend"] = nameOf(detail::kDepositionBackends, soil.deposition_backend);
  return out;
}

ordered_json toolJson(const Tool& tool, StudyKind kind) {
  ordered_json out;
  out["name"] = tool.name;
  if (hasSoil(kind)) out["dem_material"] = tool.dem_material;
  const ToolGeometry& g = tool.geometry;
  ordered_json& geometry = out["geometry"];
  geometry["kind"] = nameOf(detail::kGeometryKinds, g.kind);
  switch (g.kind) {
    case GeometryKind::Plate:
      put(geometry, "length_mm", g.length_m);
      put(geometry, "width_mm", g.width_m);
      put(geometry, "thickness_mm", g.thickness_m);
      put(geometry, "keypoint_spacing_mm", g.keypoint_spacing_m);
      break;
    case GeometryKind::Gmsh:
      put(geometry, "length_mm", g.length_m);
      geometry["mesh_file"] = g.mesh_file.string();
      break;
    case GeometryKind::MatrixMarket:
      put(geometry, "length_mm", g.length_m);
      geometry["mass_file"] = g.mass_file.string();
      geometry["stiffness_file"] = g.stiffness_file.string();
      geometry["keypoint_file"] = g.keypoint_file.string();
      break;
    case GeometryKind::Cone:
      put(geometry, "length_mm", g.length_m);
      put(geometry, "area_mm2", g.cone_area_m2);
      put(geometry, "apex_angle_deg", g.cone_angle_rad);
      put(geometry, "keypoint_spacing_mm", g.keypoint_spacing_m);
      break;
  }
  if (tool.fem.deformable || kind == StudyKind::DemOnly) {
    ordered_json& fem = out["fem"];
    if (g.kind != GeometryKind::MatrixMarket) {
      put(fem, "E_Pa", tool.fem.youngs_Pa);
      put(fem, "nu", tool.fem.poisson);
      put(fem, "density_kg_m3", tool.fem.density_kg_m3);
      fem["element_order"] = nameOf(detail::kElementOrders, tool.fem.element_order);
    }
    if (tool.fem.deformable) {
      put(fem, "alpha_s", tool.fem.alpha_s);
      put(fem, "beta_per_s", tool.fem.beta_per_s);
    }
  }
  if (g.kind != GeometryKind::Cone) {
    ordered_json& c = out["constraints"];
    put(c, "clamp_length_mm", tool.constraints.clamp_length_m);
    put(c, "load_cell_from_top_mm", tool.constraints.load_cell_from_top_m);
    put(c, "sensor_from_top_mm", tool.constraints.sensor_from_top_m);
    if (tool.constraints.clamp_rotational_stiffness_Nm_per_rad)
      put(c, "clamp_rotational_stiffness_Nm_per_rad", *tool.constraints.clamp_rotational_stiffness_Nm_per_rad);
  }
  if (tool.fem.deformable) {
    ordered_json& s = out["sensors"];
    put(s, "force_gain", tool.sensors.force_gain);
    put(s, "deformation_gain", tool.sensors.deformation_gain);
  }
  if (hasSoil(kind)) {
    ordered_json& m = out["motion"];
    put(m, "depth_mm", tool.motion.depth_m);
    put(m, "velocity_mm_s", tool.motion.velocity_m_s);
    if (g.kind != GeometryKind::Cone) put(m, "stroke_mm", tool.motion.stroke_m);
    put(m, "start_z_mm", tool.motion.start_z_m);
    put(m, "center_x_mm", tool.motion.center_x_m);
    if (g.kind != GeometryKind::Cone) put(m, "insertion_velocity_mm_s", tool.motion.insertion_velocity_m_s);
  }
  return out;
}

ordered_json demJson(const DemSettings& dem) {
  ordered_json out;
  out["backend"] = dem.backend;
  if (dem.dt_s) {
    put(out, "dt_s", *dem.dt_s);
  } else {
    out["criterion"] = nameOf(detail::kCriteria, dem.criterion);
    put(out, "dt_fraction", dem.dt_fraction);
  }
  out["threads"] = dem.threads;
  out["seed"] = dem.seed;
  return out;
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

ordered_json toJson(const Study& study) {
  ordered_json out;
  out["name"] = study.name;
  out["kind"] = nameOf(detail::kStudyKinds, study.kind);
  if (!study.notes.empty()) out["notes"] = study.notes;
  if (hasSoil(study.kind)) out["soil"] = soilJson(study.soil);
  out["tools"] = ordered_json::array();
  for (const Tool& tool : study.tools) out["tools"].push_back(toolJson(tool, study.kind));
  if (study.weight_drop) {
    ordered_json& w = out["weight_drop"];
    put(w, "mass_kg", study.weight_drop->mass_kg);
    put(w, "pan_rows_from_tip_mm", study.weight_drop->pan_rows_from_tip_m);
    put(w, "duration_s", study.weight_drop->duration_s);
  }
  put(out["fem"], "dt_s", study.fem.dt_s);
  if (hasSoil(study.kind)) {
    out["dem"] = demJson(study.dem);
    ordered_json& c = out["coupling"];
    if (!study.coupling.endpoint.empty()) c["endpoint"] = study.coupling.endpoint;
    c["force_averaging"] = nameOf(detail::kForceAveraging, study.coupling.force_averaging);
    put(c, "timeout_s", study.coupling.timeout_s);
    put(c, "max_simulate_s", study.coupling.max_simulate_s);
  }
  ordered_json& o = out["output"];
  o["directory"] = study.output.directory.string();
  o["vtk_every"] = study.output.vtk_every;
  o["csv_every"] = study.output.csv_every;
  return out;
}

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
  canonical["soil"] = nlohmann::json::parse(soilJson(soil).dump());
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
  nlohmann::json dem = nlohmann::json::parse(demJson(study.dem).dump());
  dem.erase("seed");     // the run's seed; the deposition has soil.deposition.seed
  dem.erase("threads");  // one soil for every core count
  dem.erase("backend");  // the run's backend; the deposition's is soil.deposition.backend
  canonical["dem"] = dem;
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx",
                static_cast<unsigned long long>(fnv1a64("demfem-soil-v2\n" + canonical.dump())));
  return hex;
}

}  // namespace demfem::study

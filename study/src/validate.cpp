// The cross-field rules of a study (validation.hpp), after its keys have been read: materials are
// defined once and used, layers tile the soil, the interaction table covers every pair, each tool
// fits its constraints and the bin, and the study fits the sizes the programs are built for.
#include "validation.hpp"

#include "enum_names.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <set>

namespace demfem::study::detail {

namespace {

// Lengths are compared after the mm -> m conversion; this absorbs representation error only.
constexpr double kLengthTolerance_m = 1e-12;
// Sizes the programs are built for; a study beyond them is refused, naming the key that causes it.
constexpr double kMaxParticles = 5e6;
constexpr double kMaxKeypoints = 2e5;
constexpr double kMaxFemSteps = 1e8;
constexpr double kRandomClosePacking = 0.64;  // solid fraction used to estimate the particle count

std::string mm(double metres) { return formatNumber(metres * 1e3) + " mm"; }

// Where each material name is defined and used.
struct MaterialUse {
  std::map<std::string, std::size_t> index;  // name -> first position in soil.materials
  std::set<std::string> particle;            // used by a layer
  std::set<std::string> wall;                // bin or tool
};

// Whether the values a tool's cross-field rules need were all read.
struct ToolFacts {
  std::string path;
  bool motion_ok = false;
  bool constraints_ok = false;
};

class Checker {
 public:
  Checker(const Study& study, const ReadFacts& facts, IssueList& issues)
      : study_(study), facts_(facts), issues_(issues) {}

  void run() {
    for (std::size_t i = 0; i < study_.tools.size(); ++i) tools_.push_back(toolFacts(i));
    if (hasSoil(study_.kind)) checkSoil();
    checkTools();
    if (issues_.empty()) checkSizes();
  }

 private:
  ToolFacts toolFacts(std::size_t i) const {
    const std::string path = "/tools/" + std::to_string(i);
    const Tool& tool = study_.tools[i];
    const auto ok = [&](const char* key) { return !facts_.bad(path + key); };
    bool lengths = ok("/geometry/kind");
    switch (tool.geometry.kind) {
      case GeometryKind::Plate:
        lengths = lengths && ok("/geometry/length_mm") && ok("/geometry/width_mm") && ok("/geometry/thickness_mm");
        break;
      case GeometryKind::Gmsh:
      case GeometryKind::MatrixMarket: lengths = lengths && ok("/geometry/length_mm"); break;
      case GeometryKind::Cone:
        lengths = lengths && ok("/geometry/area_mm2") && ok("/geometry/apex_angle_deg") && ok("/geometry/length_mm");
        break;
    }
    const bool cone = tool.geometry.kind == GeometryKind::Cone;
    ToolFacts f{path};
    f.constraints_ok = lengths && ok("/constraints/clamp_length_mm") && ok("/constraints/load_cell_from_top_mm") &&
                       ok("/constraints/sensor_from_top_mm");
    f.motion_ok = hasSoil(study_.kind) && lengths && ok("/motion/depth_mm") && ok("/motion/start_z_mm") &&
                  (cone || ok("/motion/stroke_mm")) && ok("/motion/center_x_mm");
    return f;
  }

  bool known(const char* path) const { return !facts_.bad(path); }

  void checkSoil() {
    const Soil& soil = study_.soil;
    if (known("/soil/particles/diameter_min_mm") && known("/soil/particles/diameter_max_mm") &&
        soil.diameter_min_m > soil.diameter_max_m)
      issues_.add("/soil/particles/diameter_min_mm",
                  "must be <= diameter_max_mm (" + mm(soil.diameter_max_m) + "), got " + mm(soil.diameter_min_m));
    for (std::size_t i = 0; i < soil.materials.size(); ++i) {
      const std::string& name = soil.materials[i].name;
      if (name.empty()) continue;
      const auto [it, inserted] = materials_.index.emplace(name, i);
      if (!inserted)
        issues_.add("/soil/materials/" + std::to_string(i) + "/name",
                    "\"" + name + "\" is already defined at /soil/materials/" + std::to_string(it->second));
    }
    const auto defined = [&](const std::string& name) { return materials_.index.count(name) > 0; };
    std::string names;
    for (const auto& m : soil.materials) names += (names.empty() ? "\"" : ", \"") + m.name + "\"";
    const auto unknownMaterial = [&](const std::string& path, const std::string& name) {
      issues_.add(path, "material \"" + name + "\" is not defined in /soil/materials (defined: " + names + ")");
    };

    if (!soil.bin_material.empty()) {
      if (defined(soil.bin_material))
        materials_.wall.insert(soil.bin_material);
      else
        unknownMaterial("/soil/bin/material", soil.bin_material);
    }
    for (std::size_t i = 0; i < study_.tools.size(); ++i) {
      const std::string& name = study_.tools[i].dem_material;
      if (name.empty()) continue;
      if (defined(name))
        materials_.wall.insert(name);
      else
        unknownMaterial(tools_[i].path + "/dem_material", name);
    }

    // Layers: tile [0, fill height] from the surface down without gaps or overlaps (Fig. 4a).
    double expected_top = 0.0;
    bool chain_ok = true;
    for (std::size_t i = 0; i < soil.layers.size(); ++i) {
      const Layer& layer = soil.layers[i];
      const std::string path = "/soil/layers/" + std::to_string(i);
      if (!layer.material.empty()) {
        if (!defined(layer.material))
          unknownMaterial(path + "/material", layer.material);
        else if (materials_.wall.count(layer.material))
          issues_.add(path + "/material", "\"" + layer.material +
                                              "\" is also a wall material (bin or tool); particles need their own");
        else
          materials_.particle.insert(layer.material);
      }
      if (facts_.bad(path + "/top_depth_mm") || facts_.bad(path + "/bottom_depth_mm")) {
        chain_ok = false;
        continue;
      }
      if (layer.bottom_depth_m <= layer.top_depth_m)
        issues_.add(path + "/bottom_depth_mm", "must be > top_depth_mm (" + mm(layer.top_depth_m) + "), got " +
                                                   mm(layer.bottom_depth_m));
      if (chain_ok && std::abs(layer.top_depth_m - expected_top) > kLengthTolerance_m)
        issues_.add(path + "/top_depth_mm",
                    (i == 0 ? std::string("the first layer must start at the surface (0 mm)")
                            : "must equal the bottom of layer " + std::to_string(i - 1) + " (" + mm(expected_top) +
                                  ") so the layers tile the soil without gaps or overlaps") +
                        ", got " + mm(layer.top_depth_m));
      expected_top = layer.bottom_depth_m;
    }
    if (chain_ok && !soil.layers.empty() && std::abs(expected_top - soil.fill_height_m) > kLengthTolerance_m)
      issues_.add("/soil/layers/" + std::to_string(soil.layers.size() - 1) + "/bottom_depth_mm",
                  "the last layer must end at fill_height_mm (" + mm(soil.fill_height_m) + "), got " + mm(expected_top));

    if (soil.diameter_max_m >= soil.fill_height_m)
      issues_.add("/soil/fill_height_mm", "must exceed the largest particle diameter (" + mm(soil.diameter_max_m) +
                                              "), got " + mm(soil.fill_height_m));
    if (soil.diameter_max_m >= std::min(soil.bin_width_m, soil.bin_length_m))
      issues_.add("/soil/particles/diameter_max_mm", "must be smaller than the bin, got " + mm(soil.diameter_max_m));

    const bool edem = known("/soil/contact/normal") && soil.contact.normal == NormalModel::EdemHysteretic;
    for (std::size_t i = 0; i < soil.materials.size(); ++i) {
      const DemMaterial& m = soil.materials[i];
      const std::string path = "/soil/materials/" + std::to_string(i);
      const bool particle = materials_.particle.count(m.name) > 0;
      if (!particle && !materials_.wall.count(m.name) && !m.name.empty())
        issues_.add(path, "material \"" + m.name + "\" is not used by a layer, the bin or a tool");
      if (particle && edem && m.yield_Pa <= 0.0)
        issues_.add(path + "/yield_Pa",
                    "must be > 0 for a particle material with the edem-hysteretic model (K1 = 5 R* Y), got " +
                        formatNumber(m.yield_Pa));
    }
    checkInteractionTable();
  }

  // Every particle-particle and particle-wall pair exactly once; walls never touch each other.
  void checkInteractionTable() {
    const Soil& soil = study_.soil;
    std::map<std::pair<std::string, std::string>, std::string> seen;  // pair -> path of its entry
    const auto key = [](const std::string& a, const std::string& b) {
      return a < b ? std::make_pair(a, b) : std::make_pair(b, a);
    };
    for (std::size_t i = 0; i < soil.interactions.size(); ++i) {
      const Interaction& entry = soil.interactions[i];
      const std::string entry_path = "/soil/interactions/" + std::to_string(i);
      const std::string path = entry_path + "/materials";
      if (entry.a.empty()) continue;
      bool defined = true;
      for (const std::string* name : {&entry.a, &entry.b}) {
        if (!materials_.index.count(*name)) {
          issues_.add(path, "material \"" + *name + "\" is not defined in /soil/materials");
          defined = false;
        }
      }
      if (!defined) continue;
      const bool a_particle = materials_.particle.count(entry.a) > 0;
      const bool b_particle = materials_.particle.count(entry.b) > 0;
      if (!a_particle && !b_particle) {
        issues_.add(path, "\"" + entry.a + "\" and \"" + entry.b +
                              "\" are both walls (or unused); walls do not touch each other in the DEM");
        continue;
      }
      const auto [it, inserted] = seen.emplace(key(entry.a, entry.b), entry_path);
      if (!inserted) issues_.add(path, "the pair (\"" + entry.a + "\", \"" + entry.b + "\") is already given at " + it->second);
    }
    std::vector<std::string> partners(materials_.particle.begin(), materials_.particle.end());
    partners.insert(partners.end(), materials_.wall.begin(), materials_.wall.end());
    for (const std::string& p : materials_.particle) {
      for (const std::string& q : partners) {
        if (materials_.particle.count(q) && q < p) continue;  // particle pairs once
        if (!seen.count(key(p, q)))
          issues_.add("/soil/interactions", "missing the pair (\"" + p + "\", \"" + q + "\")");
      }
    }
  }

  void checkTools() {
    std::map<std::string, std::string> names;
    const Soil& s = study_.soil;
    if (study_.kind == StudyKind::WeightDrop && study_.tools.size() > 1)
      issues_.add("/tools", "a weight-drop study has exactly one tool, got " + std::to_string(study_.tools.size()));
    for (std::size_t i = 0; i < study_.tools.size(); ++i) {
      const Tool& tool = study_.tools[i];
      const ToolFacts& source = tools_[i];
      const std::string& path = source.path;
      if (!tool.name.empty() && !facts_.bad(path + "/name")) {
        const auto [it, inserted] = names.emplace(tool.name, path);
        if (!inserted) issues_.add(path + "/name", "\"" + tool.name + "\" is already the name of " + it->second);
      }
      const ToolGeometry& g = tool.geometry;
      const bool cone = g.kind == GeometryKind::Cone;
      const double length = g.length_m;
      const ToolConstraints& c = tool.constraints;
      // Section 2.9: clamp at the top, load cell and sensor on the free part, below the clamp.
      if (!cone && source.constraints_ok) {
        const std::string cpath = path + "/constraints";
        if (c.clamp_length_m >= length)
          issues_.add(cpath + "/clamp_length_mm", "must be < the tool length (" + mm(length) + "), got " +
                                                      mm(c.clamp_length_m));
        for (const auto& [key, value] : {std::pair{"load_cell_from_top_mm", c.load_cell_from_top_m},
                                         std::pair{"sensor_from_top_mm", c.sensor_from_top_m}}) {
          if (value <= c.clamp_length_m || value >= length)
            issues_.add(cpath + "/" + key, "must lie on the free part of the tool, below the clamp (" +
                                               mm(c.clamp_length_m) + ") and above the tip (" + mm(length) +
                                               "), got " + mm(value));
        }
      }
      if (cone && !facts_.bad(path + "/geometry/length_mm") && !facts_.bad(path + "/geometry/area_mm2") &&
          !facts_.bad(path + "/geometry/apex_angle_deg") && length <= g.coneHeight_m())
        issues_.add(path + "/geometry/length_mm", "must exceed the cone's height (" + mm(g.coneHeight_m()) +
                                                      ", from area_mm2 and apex_angle_deg), got " + mm(length));
      if (study_.weight_drop && source.constraints_ok &&
          study_.weight_drop->pan_rows_from_tip_m >= length - c.clamp_length_m)
        issues_.add("/weight_drop/pan_rows_from_tip_mm", "must be < the free length of the tool (" +
                                                             mm(length - c.clamp_length_m) + "), got " +
                                                             mm(study_.weight_drop->pan_rows_from_tip_m));
      if (!source.motion_ok) continue;
      const ToolMotion& m = tool.motion;
      const std::string mpath = path + "/motion";
      if (m.depth_m >= s.fill_height_m)
        issues_.add(mpath + "/depth_mm", "must be < soil.fill_height_mm (" + mm(s.fill_height_m) + "), got " +
                                             mm(m.depth_m));
      if (cone && m.depth_m >= length)
        issues_.add(mpath + "/depth_mm", "must be < the penetrometer length (" + mm(length) + "), got " + mm(m.depth_m));
      if (!cone && source.constraints_ok && m.depth_m >= length - c.clamp_length_m)
        issues_.add(mpath + "/depth_mm", "must be < the tool length minus the clamp (" +
                                             mm(length - c.clamp_length_m) + "), got " + mm(m.depth_m));
      // Footprint in the bin (x across, z along). start_z is the front face of a plate (its back face
      // trails by the thickness) and the axis of a cone.
      const double half_x = cone ? g.coneRadius_m() : g.width_m / 2;
      const double behind = cone ? half_x : (g.kind == GeometryKind::Plate ? g.thickness_m : 0.0);
      const double ahead = cone ? half_x : m.stroke_m;
      if (g.kind == GeometryKind::Plate || cone) {
        if (m.center_x_m - half_x < 0 || m.center_x_m + half_x > s.bin_width_m)
          issues_.add(mpath + (facts_.center_x_given[i] ? "/center_x_mm" : ""),
                      "the tool (x from " + mm(m.center_x_m - half_x) + " to " + mm(m.center_x_m + half_x) +
                          ") must lie within the bin width (0 to " + mm(s.bin_width_m) + ")");
      }
      if (m.start_z_m - behind < 0 || m.start_z_m + ahead > s.bin_length_m)
        issues_.add(mpath + "/start_z_mm", "the tool's path (z from " + mm(m.start_z_m - behind) + " to " +
                                               mm(m.start_z_m + ahead) +
                                               ") must lie within the bin length (0 to " + mm(s.bin_length_m) + ")");
    }
    checkConeSpacing();
    if (study_.weight_drop && study_.weight_drop->duration_s < study_.fem.dt_s)
      issues_.add("/weight_drop/duration_s", "must be >= fem.dt_s (" + formatNumber(study_.fem.dt_s) + " s), got " +
                                                 formatNumber(study_.weight_drop->duration_s));
    if (hasSoil(study_.kind) && known("/coupling/max_simulate_s") && study_.coupling.max_simulate_s < study_.fem.dt_s)
      issues_.add("/coupling/max_simulate_s", "must be >= fem.dt_s (" + formatNumber(study_.fem.dt_s) +
                                                  " s, the interval the FEM client asks for), got " +
                                                  formatNumber(study_.coupling.max_simulate_s));
  }

  // Cones move side by side; their footprints must not overlap.
  void checkConeSpacing() {
    for (std::size_t i = 0; i < study_.tools.size(); ++i) {
      for (std::size_t j = i + 1; j < study_.tools.size(); ++j) {
        const Tool& a = study_.tools[i];
        const Tool& b = study_.tools[j];
        if (a.geometry.kind != GeometryKind::Cone || b.geometry.kind != GeometryKind::Cone) continue;
        if (!tools_[i].motion_ok || !tools_[j].motion_ok) continue;
        const double reach = a.geometry.coneRadius_m() + b.geometry.coneRadius_m();
        const double distance = std::hypot(a.motion.center_x_m - b.motion.center_x_m,
                                           a.motion.start_z_m - b.motion.start_z_m);
        if (distance < reach)
          issues_.add(tools_[j].path + "/motion", "the cone overlaps the cone of " + tools_[i].path + " (centres " +
                                                      mm(distance) + " apart, need >= " + mm(reach) + ")");
      }
    }
  }

  // Sizes beyond what the programs are built for (kMaxParticles, ...), estimated from the same
  // quantities the programs derive them from; judged on an otherwise valid study only.
  void checkSizes() {
    const Soil& soil = study_.soil;
    const bool has_soil = hasSoil(study_.kind);
    if (has_soil) {
      const double d = 0.5 * (soil.diameter_min_m + soil.diameter_max_m);
      const double particles = kRandomClosePacking * soil.bin_length_m * soil.bin_width_m * soil.fill_height_m /
                               (std::numbers::pi / 6 * d * d * d);
      if (particles > kMaxParticles)
        issues_.add("/soil/particles/diameter_min_mm", "the bin would hold about " + formatNumber(std::round(particles)) +
                                                           " particles of this size, more than the limit of " +
                                                           formatNumber(kMaxParticles) + ": larger particles or a smaller bin");
    }
    double simulated_s = study_.weight_drop ? study_.weight_drop->duration_s : 0.0;
    for (std::size_t i = 0; i < study_.tools.size(); ++i) {
      const ToolGeometry& g = study_.tools[i].geometry;
      const double spacing = g.keypoint_spacing_m;
      double area = 0;  // surface carrying keypoints; meshes from files bring their own
      if (g.kind == GeometryKind::Plate)
        area = 2 * (g.length_m * g.width_m + g.length_m * g.thickness_m + g.width_m * g.thickness_m);
      if (g.kind == GeometryKind::Cone)  // cone mantle, shaft mantle above the cone, top disc
        area = g.cone_area_m2 * (2 + 1 / std::sin(g.cone_angle_rad / 2)) +
               2 * std::numbers::pi * g.coneRadius_m() * std::max(0.0, g.length_m - g.coneHeight_m());
      if (area / (spacing * spacing) > kMaxKeypoints)
        issues_.add(tools_[i].path + "/geometry/keypoint_spacing_mm",
                    "gives about " + formatNumber(std::round(area / (spacing * spacing))) +
                        " keypoints, more than the limit of " + formatNumber(kMaxKeypoints) + ": a coarser spacing");
      if (!has_soil) continue;
      // Insertion from one particle diameter above the surface, then the stroke (fem/coupled_driver.hpp).
      const ToolMotion& m = study_.tools[i].motion;
      const double drop = soil.diameter_max_m + m.depth_m;
      simulated_s = std::max(simulated_s, g.kind == GeometryKind::Cone
                                              ? drop / m.velocity_m_s
                                              : drop / m.insertion_velocity_m_s + m.stroke_m / m.velocity_m_s);
    }
    if (simulated_s / study_.fem.dt_s > kMaxFemSteps)
      issues_.add("/fem/dt_s", "gives " + formatNumber(std::round(simulated_s / study_.fem.dt_s)) + " FEM steps over the " +
                                   formatNumber(simulated_s) + " s the study simulates, more than the limit of " +
                                   formatNumber(kMaxFemSteps));
    if (has_soil && study_.dem.dt_s && simulated_s / *study_.dem.dt_s > kMaxDemSteps)
      issues_.add("/dem/dt_s", "gives " + formatNumber(std::round(simulated_s / *study_.dem.dt_s)) +
                                   " DEM steps, more than the limit of " + formatNumber(kMaxDemSteps));
  }

  const Study& study_;
  const ReadFacts& facts_;
  IssueList& issues_;
  MaterialUse materials_;
  std::vector<ToolFacts> tools_;
};

}  // namespace

bool ReadFacts::bad(const std::string& path) const {
  return std::any_of(reading.begin(), reading.end(), [&](const Issue& issue) {
    return issue.path.empty() || path == issue.path || path.starts_with(issue.path + "/");
  });
}

void checkStudy(const Study& study, const ReadFacts& facts, IssueList& issues) {
  Checker(study, facts, issues).run();
}

bool isPlainName(const std::string& name) {
  return std::all_of(name.begin(), name.end(), [](unsigned char c) {
    return std::isalnum(c) || c == '_' || c == '-' || c == '.';
  });
}

}  // namespace demfem::study::detail

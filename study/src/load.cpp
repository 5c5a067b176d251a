// Study file loader: JSON text -> validated Study (SI units). Every problem is collected with its JSON
// pointer; nothing is thrown until the whole file has been checked. The file format is documented in
// docs/study-file.md, which lists the same keys, ranges and defaults as this file.
#include "demfem/study/study.hpp"

#include "enum_names.hpp"
#include "json_reader.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <numbers>
#include <set>
#include <sstream>
#include <thread>

namespace demfem::study {

namespace {

using detail::closedInterval;
using detail::formatNumber;
using detail::IssueList;
using detail::leftOpen;
using detail::Need;
using detail::nonNegative;
using detail::ObjectReader;
using detail::openInterval;
using detail::positive;
using nlohmann::json;

namespace fs = std::filesystem;

// Deepest nesting of objects and arrays a study file may have (the format needs 5).
constexpr std::size_t kMaxNestingDepth = 64;

// Lengths are compared after the mm -> m conversion; this absorbs representation error only.
constexpr double kLengthTolerance_m = 1e-12;
// Physical ranges of the numbers, in file units (docs/study-file.md lists them with the keys).
constexpr double kMaxLength_mm = 1e5;            // 100 m: any length, depth or distance
constexpr double kMinDiameter_mm = 1e-3, kMaxDiameter_mm = 1e3;
constexpr double kMinDensity = 1.0, kMaxDensity = 3e4;  // kg/m^3: aerogel to osmium
constexpr double kMinModulus_Pa = 1e3, kMaxModulus_Pa = 1e13;  // above diamond
constexpr double kMaxFriction = 10.0;
constexpr double kMaxVelocity_mm_s = 1e5;        // 100 m/s
constexpr double kMinFemStep_s = 1e-9, kMinDemStep_s = 1e-12;
constexpr double kMaxSimulateLimitS = 3600.0;    // coupling.max_simulate_s: an hour per call
constexpr long long kMaxThreads = 1024;
// Sizes the programs are built for; a study beyond them is refused, naming the key that causes it.
constexpr double kMaxParticles = 5e6;
constexpr double kMaxKeypoints = 2e5;
constexpr double kMaxFemSteps = 1e8;
constexpr double kMaxDemSteps = 1e11;
constexpr double kRandomClosePacking = 0.64;  // solid fraction used to estimate the particle count

std::string mm(double metres) { return formatNumber(metres * 1e3) + " mm"; }

Need needIf(bool condition) { return condition ? Need::Required : Need::Optional; }

// True if `path` exists and is not a socket (ZeroMQ unlinks an ipc path before binding it).
bool existsAsNonSocket(const std::string& path) {
  std::error_code error;
  const fs::file_status status = fs::symlink_status(path, error);
  return fs::exists(status) && status.type() != fs::file_type::socket;
}

bool isPlainName(const std::string& name) {
  return std::all_of(name.begin(), name.end(), [](unsigned char c) {
    return std::isalnum(c) || c == '_' || c == '-' || c == '.';
  });
}

const char* kindName(StudyKind kind) { return detail::nameOf(detail::kStudyKinds, kind).c_str(); }

// Where each material name is defined and used, for the cross-field checks.
struct MaterialUse {
  std::map<std::string, std::size_t> index;  // name -> position in soil.materials
  std::set<std::string> particle;            // used by a layer
  std::set<std::string> wall;                // bin or tool
};

// Where each tool came from, and whether the values its cross-field checks need were all valid
// (an invalid value is reported once, where it is, not again by every rule that uses it).
struct ToolSource {
  std::string path;
  bool motion_ok = false;
  bool constraints_ok = false;
};

class StudyParser {
 public:
  StudyParser(const fs::path& origin, IssueList& issues)
      : base_dir_(origin.parent_path()), issues_(issues) {
    study_.source = origin;
  }

  Study parse(const json& root) {
    ObjectReader top(&root, "", issues_);
    if (!top.valid()) return study_;
    if (auto name = top.string("name", Need::Required)) {
      if (isPlainName(*name))
        study_.name = *name;
      else
        issues_.add("/name", "must contain only letters, digits, '_', '-' and '.' (it names output files), got \"" +
                                 *name + "\"");
    }
    readNotes(top, root);
    const std::optional<StudyKind> kind = top.choice("kind", detail::kStudyKinds, Need::Required);
    if (!kind) {
      // Without a kind the sections cannot be judged; check only that they are known.
      for (const char* key : {"soil", "tools", "weight_drop", "fem", "dem", "coupling", "output"}) top.known(key);
      top.finish();
      return study_;
    }
    study_.kind = *kind;
    const bool soil = hasSoil(*kind);
    const std::string kind_text = std::string("a ") + kindName(*kind) + " study";

    if (soil) {
      ObjectReader section = top.object("soil", Need::Required);
      readSoil(section);
    } else {
      top.forbid("soil", kind_text + " simulates no soil");
    }
    if (const json* tools = top.array("tools", Need::Required, 1)) {
      for (std::size_t i = 0; i < tools->size(); ++i) readTool((*tools)[i], "/tools/" + std::to_string(i));
    }
    if (*kind == StudyKind::WeightDrop) {
      ObjectReader section = top.object("weight_drop", Need::Required);
      readWeightDrop(section);
    } else {
      top.forbid("weight_drop", "only a weight-drop study hangs a calibration weight");
    }
    {
      ObjectReader section = top.object("fem", Need::Required);
      readFemSettings(section);
    }
    if (soil) {
      ObjectReader dem = top.object("dem", Need::Required);
      readDem(dem);
      ObjectReader coupling = top.object("coupling", Need::Optional);
      readCoupling(coupling);
    } else {
      top.forbid("dem", kind_text + " runs no DEM");
      top.forbid("coupling", kind_text + " runs no DEM to couple to");
    }
    ObjectReader output = top.object("output", Need::Optional);
    readOutput(output);
    top.finish();

    if (soil) checkSoil();
    checkTools();
    if (issues_.empty()) checkSizes();
    return study_;
  }

 private:
  // `notes`: free text, a string or an array of lines (long explanations stay readable in the file).
  void readNotes(ObjectReader& top, const json& root) {
    top.known("notes");
    if (!top.has("notes")) return;
    const json& notes = root["notes"];
    if (notes.is_string()) {
      study_.notes = notes.get<std::string>();
      return;
    }
    if (notes.is_array() && std::all_of(notes.begin(), notes.end(), [](const json& l) { return l.is_string(); })) {
      for (std::size_t i = 0; i < notes.size(); ++i) study_.notes += (i ? "\n" : "") + notes[i].get<std::string>();
      return;
    }
    issues_.add("/notes", "must be a string or an array of strings, got " + detail::describeValue(notes));
  }

  void readSoil(ObjectReader& o) {
    Soil& soil = study_.soil;
    {
      ObjectReader bin = o.object("bin", Need::Required);
      if (auto v = bin.quantity("length_mm", leftOpen(0.0, kMaxLength_mm), Need::Required)) soil.bin_length_m = *v;
      if (auto v = bin.quantity("width_mm", leftOpen(0.0, kMaxLength_mm), Need::Required)) soil.bin_width_m = *v;
      if (auto v = bin.string("material", Need::Required)) soil.bin_material = *v;
      bin.finish();
    }
    if (auto v = o.quantity("fill_height_mm", leftOpen(0.0, kMaxLength_mm), Need::Required)) soil.fill_height_m = *v;
    {
      ObjectReader particles = o.object("particles", Need::Required);
      const auto dmin = particles.quantity("diameter_min_mm", closedInterval(kMinDiameter_mm, kMaxDiameter_mm), Need::Required);
      const auto dmax = particles.quantity("diameter_max_mm", closedInterval(kMinDiameter_mm, kMaxDiameter_mm), Need::Required);
      if (dmin) soil.diameter_min_m = *dmin;
      if (dmax) soil.diameter_max_m = *dmax;
      if (dmin && dmax && *dmin > *dmax)
        issues_.add(particles.pathOf("diameter_min_mm"),
                    "must be <= diameter_max_mm (" + mm(*dmax) + "), got " + mm(*dmin));
      particles.finish();
    }
    if (const json* materials = o.array("materials", Need::Required, 1)) {
      for (std::size_t i = 0; i < materials->size(); ++i) readMaterial((*materials)[i], i);
    }
    {
      ObjectReader contact = o.object("contact", Need::Required);
      readContact(contact);
    }
    if (const json* layers = o.array("layers", Need::Required, 1)) {
      for (std::size_t i = 0; i < layers->size(); ++i) {
        ObjectReader l(&(*layers)[i], "/soil/layers/" + std::to_string(i), issues_);
        Layer layer;
        if (auto v = l.string("material", Need::Required)) layer.material = *v;
        const auto top = l.quantity("top_depth_mm", closedInterval(0.0, kMaxLength_mm), Need::Required);
        const auto bottom = l.quantity("bottom_depth_mm", leftOpen(0.0, kMaxLength_mm), Need::Required);
        if (top) layer.top_depth_m = *top;
        if (bottom) layer.bottom_depth_m = *bottom;
        layer_ok_.push_back(top && bottom);
        l.finish();
        soil.layers.push_back(layer);
      }
    }
    if (const json* interactions = o.array("interactions", Need::Required, 1)) {
      for (std::size_t i = 0; i < interactions->size(); ++i) readInteraction((*interactions)[i], i);
    }
    ObjectReader deposition = o.object("deposition", Need::Optional);
    if (auto v = deposition.integer("seed", 0, INT64_MAX, Need::Optional)) soil.deposition_seed = static_cast<std::uint64_t>(*v);
    if (auto v = deposition.quantity("settle_kinetic_energy_J", leftOpen(0.0, 1e6), Need::Optional))
      soil.settle_kinetic_energy_J = *v;
    if (auto v = deposition.choice("backend", detail::kDepositionBackends, Need::Optional)) soil.deposition_backend = *v;
    deposition.finish();
    o.finish();
  }

  void readMaterial(const json& value, std::size_t i) {
    const std::string path = "/soil/materials/" + std::to_string(i);
    ObjectReader m(&value, path, issues_);
    DemMaterial material;
    if (auto v = m.string("name", Need::Required)) {
      material.name = *v;
      const auto [it, inserted] = materials_.index.emplace(*v, study_.soil.materials.size());
      if (!inserted)
        issues_.add(path + "/name", "\"" + *v + "\" is already defined at /soil/materials/" +
                                        std::to_string(material_path_index_[it->second]));
    }
    if (auto v = m.quantity("density_kg_m3", closedInterval(kMinDensity, kMaxDensity), Need::Required)) material.density_kg_m3 = *v;
    if (auto v = m.quantity("E_Pa", closedInterval(kMinModulus_Pa, kMaxModulus_Pa), Need::Required)) material.youngs_Pa = *v;
    if (auto v = m.quantity("nu", openInterval(-1.0, 0.5), Need::Required)) material.poisson = *v;
    if (auto v = m.quantity("yield_Pa", closedInterval(0.0, kMaxModulus_Pa), Need::Required)) material.yield_Pa = *v;
    m.finish();
    material_path_index_.push_back(i);
    study_.soil.materials.push_back(material);
  }

  void readContact(ObjectReader& c) {
    ContactModel& model = study_.soil.contact;
    normal_ = c.choice("normal", detail::kNormalModels, Need::Required);
    cohesion_ = c.choice("cohesion", detail::kCohesionModels, Need::Required);
    rolling_ = c.choice("rolling", detail::kRollingModels, Need::Required);
    if (normal_) model.normal = *normal_;
    if (cohesion_) model.cohesion = *cohesion_;
    if (rolling_) model.rolling = *rolling_;
    if (auto v = c.boolean("tangential_history", Need::Optional)) model.tangential_history = *v;
    // Parameters of one normal model only; with an invalid model name they are accepted unjudged.
    const auto param = [&](const char* key, detail::Limits limits, bool applies, const std::string& models,
                           double& target) {
      if (normal_ && !applies) {
        c.forbid(key, "only used by contact.normal " + models + ", not \"" +
                          detail::nameOf(detail::kNormalModels, *normal_) + "\"");
        return;
      }
      if (auto v = c.quantity(key, limits, needIf(normal_.has_value()))) target = *v;
    };
    const bool edem = normal_ == NormalModel::EdemHysteretic;
    const bool hooke = normal_ == NormalModel::Hooke || normal_ == NormalModel::HookeHysteresis;
    const bool hysteresis = normal_ == NormalModel::HookeHysteresis;
    param("stiffness_factor", leftOpen(0.0, 100.0), edem, "\"edem-hysteretic\"", model.stiffness_factor);
    param("damping_factor", closedInterval(0.0, 100.0), edem, "\"edem-hysteretic\"", model.damping_factor);
    param("characteristic_velocity_m_s", leftOpen(0.0, 1e4), hooke, "\"hooke\" and \"hooke-hysteresis\"",
          model.characteristic_velocity_m_s);
    param("coefficient_max_elastic_stiffness", leftOpen(1.0, 1e3), hysteresis,
          "\"hooke-hysteresis\"", model.coefficient_max_elastic_stiffness);
    param("coefficient_plasticity_depth", leftOpen(0.0, 100.0), hysteresis, "\"hooke-hysteresis\"",
          model.coefficient_plasticity_depth);
    param("coefficient_adhesion_stiffness", closedInterval(0.0, 1e3), hysteresis, "\"hooke-hysteresis\"",
          model.coefficient_adhesion_stiffness);
    c.finish();
  }

  void readInteraction(const json& value, std::size_t i) {
    const std::string path = "/soil/interactions/" + std::to_string(i);
    ObjectReader r(&value, path, issues_);
    Interaction entry;
    if (const json* pair = r.array("materials", Need::Required)) {
      if (pair->size() == 2 && (*pair)[0].is_string() && (*pair)[1].is_string() &&
          !(*pair)[0].get<std::string>().empty() && !(*pair)[1].get<std::string>().empty()) {
        entry.a = (*pair)[0].get<std::string>();
        entry.b = (*pair)[1].get<std::string>();
      } else {
        issues_.add(path + "/materials", "must be an array of two material names, got " + pair->dump());
      }
    }
    if (auto v = r.quantity("restitution", leftOpen(0.0, 1.0), Need::Required)) entry.restitution = *v;
    if (auto v = r.quantity("static_friction", closedInterval(0.0, kMaxFriction), Need::Required)) entry.static_friction = *v;
    if (rolling_ == RollingModel::None)
      r.forbid("rolling_friction", "soil.contact.rolling is \"none\"");
    else if (auto v = r.quantity("rolling_friction", closedInterval(0.0, kMaxFriction), needIf(rolling_.has_value())))
      entry.rolling_friction = *v;
    if (cohesion_ == CohesionModel::None)
      r.forbid("cohesion_J_m3", "soil.contact.cohesion is \"none\"");
    else if (auto v = r.quantity("cohesion_J_m3", closedInterval(0.0, 1e9), needIf(cohesion_.has_value())))
      entry.cohesion_J_m3 = *v;
    r.finish();
    interaction_paths_.push_back(path);
    study_.soil.interactions.push_back(entry);
  }

  void readTool(const json& value, const std::string& path) {
    ObjectReader t(&value, path, issues_);
    Tool tool;
    ToolSource source{path};
    const StudyKind kind = study_.kind;
    const bool soil = hasSoil(kind);
    if (auto v = t.string("name", Need::Required)) {
      if (!isPlainName(*v))
        issues_.add(path + "/name", "must contain only letters, digits, '_', '-' and '.', got \"" + *v + "\"");
      tool.name = *v;
    }
    if (soil) {
      if (auto v = t.string("dem_material", Need::Required)) tool.dem_material = *v;
    } else {
      t.forbid("dem_material", std::string("a ") + kindName(kind) + " study has no particles to touch the tool");
    }
    ObjectReader g = t.object("geometry", Need::Required);
    const std::optional<GeometryKind> geometry = g.choice("kind", detail::kGeometryKinds, Need::Required);
    if (geometry) tool.geometry.kind = *geometry;
    const bool geometry_lengths_ok = readGeometry(g, tool.geometry, geometry);
    const bool cone = geometry == GeometryKind::Cone;
    if (geometry && cone != (kind == StudyKind::ConePenetration))
      issues_.add(g.pathOf("kind"), cone ? "a cone is only used by a cone-penetration study"
                                         : "a cone-penetration study needs geometry kind \"cone\"");

    const bool deformable = kind == StudyKind::Coupled || kind == StudyKind::WeightDrop || kind == StudyKind::FemOnly;
    tool.fem.deformable = deformable;
    if (deformable || kind == StudyKind::DemOnly) {
      // A DEM-only tool is rigid, but its load cell reads the static split of its FEM model.
      ObjectReader f = t.object("fem", Need::Required);
      readToolFem(f, tool.fem, geometry == GeometryKind::MatrixMarket, deformable);
    } else {
      t.forbid("fem", std::string("the tool of a ") + kindName(kind) + " study is rigid");
    }
    if (!cone) {
      ObjectReader c = t.object("constraints", Need::Required);
      const auto clamp = c.quantity("clamp_length_mm", leftOpen(0.0, kMaxLength_mm), Need::Required);
      const auto load_cell = c.quantity("load_cell_from_top_mm", leftOpen(0.0, kMaxLength_mm), Need::Required);
      const auto sensor = c.quantity("sensor_from_top_mm", leftOpen(0.0, kMaxLength_mm), Need::Required);
      if (clamp) tool.constraints.clamp_length_m = *clamp;
      if (load_cell) tool.constraints.load_cell_from_top_m = *load_cell;
      if (sensor) tool.constraints.sensor_from_top_m = *sensor;
      tool.constraints.clamp_rotational_stiffness_Nm_per_rad =
          deformable ? c.quantity("clamp_rotational_stiffness_Nm_per_rad", leftOpen(0.0, 1e9), Need::Optional) : std::nullopt;
      if (!deformable) c.forbid("clamp_rotational_stiffness_Nm_per_rad", "the tool is rigid (no FEM model to hold)");
      source.constraints_ok = clamp && load_cell && sensor && geometry_lengths_ok;
      c.finish();
    } else {
      t.forbid("constraints", "a penetrometer is rigid and has no clamp or sensors");
    }
    if (deformable) {
      ObjectReader s = t.object("sensors", Need::Optional);
      if (auto v = s.quantity("force_gain", leftOpen(0.0, 100.0), Need::Optional)) tool.sensors.force_gain = *v;
      if (auto v = s.quantity("deformation_gain", leftOpen(0.0, 100.0), Need::Optional)) tool.sensors.deformation_gain = *v;
      s.finish();
    } else {
      t.forbid("sensors", "sensor gains apply to the FEM tool's load cell and deformation sensor");
    }
    if (soil) {
      ObjectReader m = t.object("motion", Need::Required);
      const auto depth = m.quantity("depth_mm", leftOpen(0.0, kMaxLength_mm), Need::Required);
      if (depth) tool.motion.depth_m = *depth;
      if (auto v = m.quantity("velocity_mm_s", leftOpen(0.0, kMaxVelocity_mm_s), Need::Required)) tool.motion.velocity_m_s = *v;
      const auto start_z = m.quantity("start_z_mm", closedInterval(-kMaxLength_mm, kMaxLength_mm), Need::Required);
      if (start_z) tool.motion.start_z_m = *start_z;
      const auto center_x = m.quantity("center_x_mm", closedInterval(-kMaxLength_mm, kMaxLength_mm), Need::Optional);
      if (center_x) tool.motion.center_x_m = *center_x;
      center_x_given_.push_back(m.has("center_x_mm"));
      bool stroke_ok = true;
      if (cone) {
        const std::string why = "a cone moves straight down at velocity_mm_s until its tip reaches depth_mm";
        m.forbid("stroke_mm", why);
        m.forbid("insertion_velocity_mm_s", why);
      } else {
        const auto stroke = m.quantity("stroke_mm", leftOpen(0.0, kMaxLength_mm), Need::Required);
        if (stroke) tool.motion.stroke_m = *stroke;
        stroke_ok = stroke.has_value();
        if (auto v = m.quantity("insertion_velocity_mm_s", leftOpen(0.0, kMaxVelocity_mm_s), Need::Required))
          tool.motion.insertion_velocity_m_s = *v;
      }
      source.motion_ok = depth && start_z && stroke_ok && (center_x || !m.has("center_x_mm")) && geometry_lengths_ok;
      m.finish();
    } else {
      center_x_given_.push_back(false);
      t.forbid("motion", std::string("a ") + kindName(kind) + " study does not move the tool");
    }
    t.finish();
    tool_sources_.push_back(source);
    study_.tools.push_back(tool);
  }

  // Returns whether every size the cross-field checks need was read.
  bool readGeometry(ObjectReader& g, ToolGeometry& geometry, std::optional<GeometryKind> kind) {
    bool sizes_ok = kind.has_value();
    struct KeyUse {
      const char* key;
      std::vector<GeometryKind> kinds;
    };
    using K = GeometryKind;
    const std::vector<KeyUse> keys{
        {"length_mm", {K::Plate, K::Gmsh, K::MatrixMarket, K::Cone}},
        {"width_mm", {K::Plate}},
        {"thickness_mm", {K::Plate}},
        {"keypoint_spacing_mm", {K::Plate, K::Cone}},
        {"mesh_file", {K::Gmsh}},
        {"mass_file", {K::MatrixMarket}},
        {"stiffness_file", {K::MatrixMarket}},
        {"keypoint_file", {K::MatrixMarket}},
        {"area_mm2", {K::Cone}},
        {"apex_angle_deg", {K::Cone}},
    };
    for (const KeyUse& use : keys) {
      if (!kind) {
        g.known(use.key);
        continue;
      }
      if (std::find(use.kinds.begin(), use.kinds.end(), *kind) == use.kinds.end()) {
        std::string kinds;
        for (K k : use.kinds) kinds += (kinds.empty() ? "\"" : ", \"") + detail::nameOf(detail::kGeometryKinds, k) + "\"";
        g.forbid(use.key, "only used by geometry kind " + kinds);
        continue;
      }
      const std::string key = use.key;
      if (key == "length_mm") {
        if (auto v = g.quantity(key, leftOpen(0.0, kMaxLength_mm), Need::Required))
          geometry.length_m = *v;
        else
          sizes_ok = false;
      } else if (key == "width_mm") {
        if (auto v = g.quantity(key, leftOpen(0.0, kMaxLength_mm), Need::Required))
          geometry.width_m = *v;
        else
          sizes_ok = false;
      } else if (key == "thickness_mm") {
        if (auto v = g.quantity(key, leftOpen(0.0, kMaxLength_mm), Need::Required))
          geometry.thickness_m = *v;
        else
          sizes_ok = false;
      } else if (key == "keypoint_spacing_mm") {
        if (auto v = g.quantity(key, leftOpen(0.0, kMaxLength_mm), Need::Optional)) geometry.keypoint_spacing_m = *v;
      } else if (key == "area_mm2") {
        if (auto v = g.quantity(key, leftOpen(0.0, kMaxLength_mm * kMaxLength_mm), Need::Required))
          geometry.cone_area_m2 = *v;
        else
          sizes_ok = false;
      } else if (key == "apex_angle_deg") {
        if (auto v = g.quantity(key, openInterval(0.0, 180.0), Need::Required)) geometry.cone_angle_rad = *v;
      } else {
        const std::optional<fs::path> file = existingFile(g, key);
        if (!file) continue;
        if (key == "mesh_file") geometry.mesh_file = *file;
        if (key == "mass_file") geometry.mass_file = *file;
        if (key == "stiffness_file") geometry.stiffness_file = *file;
        if (key == "keypoint_file") geometry.keypoint_file = *file;
      }
    }
    g.finish();
    return sizes_ok;
  }

  // A file named relative to the study file's directory; must exist.
  std::optional<fs::path> existingFile(ObjectReader& o, const std::string& key) {
    const std::optional<std::string> name = o.string(key, Need::Required);
    if (!name) return std::nullopt;
    const fs::path file = fs::absolute(base_dir_ / fs::path(*name)).lexically_normal();
    std::error_code error;
    if (!fs::is_regular_file(file, error)) {
      issues_.add(o.pathOf(key), "file not found: " + file.string());
      return std::nullopt;
    }
    return file;
  }

  void readToolFem(ObjectReader& f, ToolFem& fem, bool matrices_given, bool dynamic) {
    if (matrices_given) {
      const std::string why = "the mass and stiffness matrices of a \"matrix-market\" geometry already contain it";
      for (const char* key : {"E_Pa", "nu", "density_kg_m3", "element_order"}) f.forbid(key, why);
    } else {
      if (auto v = f.quantity("E_Pa", closedInterval(kMinModulus_Pa, kMaxModulus_Pa), Need::Required)) fem.youngs_Pa = *v;
      if (auto v = f.quantity("nu", openInterval(-1.0, 0.5), Need::Required)) fem.poisson = *v;
      if (auto v = f.quantity("density_kg_m3", closedInterval(kMinDensity, kMaxDensity), Need::Required)) fem.density_kg_m3 = *v;
      if (auto v = f.choice("element_order", detail::kElementOrders, Need::Optional)) fem.element_order = *v;
    }
    if (!dynamic) {
      const std::string why = "a rigid tool is not integrated in time (its FEM model gives the load cell's static split)";
      for (const char* key : {"alpha_s", "beta_per_s"}) f.forbid(key, why);
    } else {
      if (auto v = f.quantity("alpha_s", closedInterval(0.0, 1.0), Need::Required)) fem.alpha_s = *v;  // Eq (4)
      if (auto v = f.quantity("beta_per_s", closedInterval(0.0, 1e6), Need::Required)) fem.beta_per_s = *v;
    }
    f.finish();
  }

  void readWeightDrop(ObjectReader& w) {
    WeightDrop drop;
    if (auto v = w.quantity("mass_kg", leftOpen(0.0, 1e4), Need::Required)) drop.mass_kg = *v;
    if (auto v = w.quantity("pan_rows_from_tip_mm", leftOpen(0.0, kMaxLength_mm), Need::Required)) drop.pan_rows_from_tip_m = *v;
    if (auto v = w.quantity("duration_s", leftOpen(0.0, 1e5), Need::Required)) drop.duration_s = *v;
    w.finish();
    study_.weight_drop = drop;
  }

  void readFemSettings(ObjectReader& f) {
    if (auto v = f.quantity("dt_s", closedInterval(kMinFemStep_s, 1.0), Need::Required)) study_.fem.dt_s = *v;
    f.finish();
  }

  void readDem(ObjectReader& d) {
    DemSettings& dem = study_.dem;
    if (auto v = d.string("backend", Need::Optional)) {
      if (isPlainName(*v))
        dem.backend = *v;
      else
        issues_.add(d.pathOf("backend"), "must be a backend name such as \"builtin\" or \"liggghts\", got \"" + *v + "\"");
    }
    if (d.has("dt_s")) {
      if (auto v = d.quantity("dt_s", closedInterval(kMinDemStep_s, 1e-2), Need::Required)) dem.dt_s = *v;
      d.forbid("criterion", "dem.dt_s sets the time step explicitly");
      d.forbid("dt_fraction", "dem.dt_s sets the time step explicitly");
    } else {
      d.known("dt_s");
      if (auto v = d.choice("criterion", detail::kCriteria, Need::Required)) dem.criterion = *v;
      if (auto v = d.quantity("dt_fraction", leftOpen(0.0, 1.0), Need::Required)) dem.dt_fraction = *v;
    }
    // Default: every core of this machine (results are reproducible per thread count).
    dem.threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
    if (auto v = d.integer("threads", 1, kMaxThreads, Need::Optional)) dem.threads = static_cast<int>(*v);
    if (auto v = d.integer("seed", 0, INT64_MAX, Need::Optional)) dem.seed = static_cast<std::uint64_t>(*v);
    d.finish();
  }

  void readCoupling(ObjectReader& c) {
    CouplingSettings& coupling = study_.coupling;
    if (auto v = c.string("endpoint", Need::Optional)) {
      if (v->starts_with("ipc://") && existsAsNonSocket(v->substr(6)))
        issues_.add(c.pathOf("endpoint"), "the ipc path " + v->substr(6) +
                                              " exists and is not a socket: binding would delete it; name a path "
                                              "that does not exist (or leave the endpoint to demfem run)");
      else if (v->starts_with("inproc://") || v->starts_with("ipc://") || v->starts_with("tcp://"))
        coupling.endpoint = *v;
      else
        issues_.add(c.pathOf("endpoint"), "must start with inproc://, ipc:// or tcp://, got \"" + *v + "\"");
    }
    if (auto v = c.choice("force_averaging", detail::kForceAveraging, Need::Optional)) coupling.force_averaging = *v;
    if (auto v = c.quantity("timeout_s", leftOpen(0.0, 86400.0), Need::Optional)) coupling.timeout_s = *v;
    if (auto v = c.quantity("max_simulate_s", leftOpen(0.0, kMaxSimulateLimitS), Need::Optional)) {
      coupling.max_simulate_s = *v;
      if (*v < study_.fem.dt_s)
        issues_.add(c.pathOf("max_simulate_s"), "must be >= fem.dt_s (" + formatNumber(study_.fem.dt_s) +
                                                    " s, the interval the FEM client asks for), got " + formatNumber(*v));
    }
    c.finish();
  }

  void readOutput(ObjectReader& o) {
    OutputSettings& output = study_.output;
    output.directory = fs::path("out") / study_.name;
    if (auto v = o.string("directory", Need::Optional)) output.directory = *v;
    if (auto v = o.integer("vtk_every", 0, INT32_MAX, Need::Optional)) output.vtk_every = static_cast<int>(*v);
    if (auto v = o.integer("csv_every", 1, INT32_MAX, Need::Optional)) output.csv_every = static_cast<int>(*v);
    o.finish();
  }

  // --- cross-field rules ---------------------------------------------------------------------

  void checkSoil() {
    const Soil& soil = study_.soil;
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
        unknownMaterial(tool_sources_[i].path + "/dem_material", name);
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
      if (!layer_ok_[i]) {
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

    for (std::size_t i = 0; i < soil.materials.size(); ++i) {
      const DemMaterial& m = soil.materials[i];
      const std::string path = "/soil/materials/" + std::to_string(material_path_index_[i]);
      const bool particle = materials_.particle.count(m.name) > 0;
      if (!particle && !materials_.wall.count(m.name) && !m.name.empty())
        issues_.add(path, "material \"" + m.name + "\" is not used by a layer, the bin or a tool");
      if (particle && normal_ == NormalModel::EdemHysteretic && m.yield_Pa <= 0.0)
        issues_.add(path + "/yield_Pa",
                    "must be > 0 for a particle material with the edem-hysteretic model (K1 = 5 R* Y), got " +
                        formatNumber(m.yield_Pa));
    }
    checkInteractionTable();
    checkBackendModels();
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
      const std::string path = interaction_paths_[i] + "/materials";
      if (entry.a.empty()) continue;
      bool known = true;
      for (const std::string* name : {&entry.a, &entry.b}) {
        if (!materials_.index.count(*name)) {
          issues_.add(path, "material \"" + *name + "\" is not defined in /soil/materials");
          known = false;
        }
      }
      if (!known) continue;
      const bool a_particle = materials_.particle.count(entry.a) > 0;
      const bool b_particle = materials_.particle.count(entry.b) > 0;
      if (!a_particle && !b_particle) {
        issues_.add(path, "\"" + entry.a + "\" and \"" + entry.b +
                              "\" are both walls (or unused); walls do not touch each other in the DEM");
        continue;
      }
      const auto [it, inserted] = seen.emplace(key(entry.a, entry.b), interaction_paths_[i]);
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

  // The LIGGGHTS backend offers only its own contact laws (docs/architecture.md section 11), also
  // when it only deposits the soil.
  void checkBackendModels() {
    if (study_.dem.backend != "liggghts" && study_.soil.deposition_backend != DepositionBackend::Liggghts) return;
    const ContactModel& c = study_.soil.contact;
    if (normal_ == NormalModel::EdemHysteretic)
      issues_.add("/soil/contact/normal", "\"edem-hysteretic\" is not available in the liggghts backend; use "
                                          "\"hooke\" or \"hooke-hysteresis\"");
    if (cohesion_ && c.cohesion == CohesionModel::EdemLinear)
      issues_.add("/soil/contact/cohesion", "\"edem-linear\" is not available in the liggghts backend; use \"sjkr\" "
                                            "or \"sjkr2\"");
    if (rolling_ && c.rolling == RollingModel::EdemStandard)
      issues_.add("/soil/contact/rolling", "\"edem-standard\" is not available in the liggghts backend; use \"cdt\" "
                                           "or \"epsd\"");
  }

  void checkTools() {
    std::map<std::string, std::string> names;
    const bool soil = hasSoil(study_.kind);
    const Soil& s = study_.soil;
    if (study_.kind == StudyKind::WeightDrop && study_.tools.size() > 1)
      issues_.add("/tools", "a weight-drop study has exactly one tool, got " + std::to_string(study_.tools.size()));
    for (std::size_t i = 0; i < study_.tools.size(); ++i) {
      Tool& tool = study_.tools[i];
      const ToolSource& source = tool_sources_[i];
      const std::string& path = source.path;
      if (!tool.name.empty()) {
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
      if (cone && length > 0 && length <= g.coneHeight_m())
        issues_.add(path + "/geometry/length_mm", "must exceed the cone's height (" + mm(g.coneHeight_m()) +
                                                      ", from area_mm2 and apex_angle_deg), got " + mm(length));
      if (study_.weight_drop && source.constraints_ok &&
          study_.weight_drop->pan_rows_from_tip_m >= length - c.clamp_length_m)
        issues_.add("/weight_drop/pan_rows_from_tip_mm", "must be < the free length of the tool (" +
                                                             mm(length - c.clamp_length_m) + "), got " +
                                                             mm(study_.weight_drop->pan_rows_from_tip_m));
      if (!soil || !source.motion_ok) continue;
      ToolMotion& m = tool.motion;
      if (!center_x_given_[i]) m.center_x_m = s.bin_width_m / 2;
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
          issues_.add(mpath + (center_x_given_[i] ? "/center_x_mm" : ""),
                      "the tool (x from " + mm(m.center_x_m - half_x) + " to " + mm(m.center_x_m + half_x) +
                          ") must lie within the bin width (0 to " + mm(s.bin_width_m) + ")");
      }
      if (m.start_z_m - behind < 0 || m.start_z_m + ahead > s.bin_length_m)
        issues_.add(mpath + "/start_z_mm", "the tool's path (z from " + mm(m.start_z_m - behind) + " to " +
                                               mm(m.start_z_m + ahead) +
                                               ") must lie within the bin length (0 to " + mm(s.bin_length_m) + ")");
    }
    // Cones move side by side; their footprints must not overlap.
    for (std::size_t i = 0; i < study_.tools.size(); ++i) {
      for (std::size_t j = i + 1; j < study_.tools.size(); ++j) {
        const Tool& a = study_.tools[i];
        const Tool& b = study_.tools[j];
        if (a.geometry.kind != GeometryKind::Cone || b.geometry.kind != GeometryKind::Cone) continue;
        if (!tool_sources_[i].motion_ok || !tool_sources_[j].motion_ok) continue;
        const double reach = a.geometry.coneRadius_m() + b.geometry.coneRadius_m();
        const double distance = std::hypot(a.motion.center_x_m - b.motion.center_x_m,
                                           a.motion.start_z_m - b.motion.start_z_m);
        if (distance < reach)
          issues_.add(tool_sources_[j].path + "/motion", "the cone overlaps the cone of " + tool_sources_[i].path +
                                                             " (centres " + mm(distance) + " apart, need >= " +
                                                             mm(reach) + ")");
      }
    }
    if (study_.weight_drop && study_.weight_drop->duration_s < study_.fem.dt_s)
      issues_.add("/weight_drop/duration_s", "must be >= fem.dt_s (" + formatNumber(study_.fem.dt_s) + " s), got " +
                                                 formatNumber(study_.weight_drop->duration_s));
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
      const Tool& tool = study_.tools[i];
      const ToolGeometry& g = tool.geometry;
      const double spacing = g.keypoint_spacing_m;
      double area = 0;  // surface carrying keypoints; meshes from files bring their own
      if (g.kind == GeometryKind::Plate)
        area = 2 * (g.length_m * g.width_m + g.length_m * g.thickness_m + g.width_m * g.thickness_m);
      if (g.kind == GeometryKind::Cone)  // cone mantle, shaft mantle above the cone, top disc
        area = g.cone_area_m2 * (2 + 1 / std::sin(g.cone_angle_rad / 2)) +
               2 * std::numbers::pi * g.coneRadius_m() * std::max(0.0, g.length_m - g.coneHeight_m());
      if (area / (spacing * spacing) > kMaxKeypoints)
        issues_.add(tool_sources_[i].path + "/geometry/keypoint_spacing_mm",
                    "gives about " + formatNumber(std::round(area / (spacing * spacing))) +
                        " keypoints, more than the limit of " + formatNumber(kMaxKeypoints) + ": a coarser spacing");
      if (!has_soil) continue;
      // Insertion from one particle diameter above the surface, then the stroke (fem/coupled_driver.hpp).
      const ToolMotion& m = tool.motion;
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

  Study study_;
  fs::path base_dir_;
  IssueList& issues_;
  std::optional<NormalModel> normal_;
  std::optional<CohesionModel> cohesion_;
  std::optional<RollingModel> rolling_;
  MaterialUse materials_;
  std::vector<std::size_t> material_path_index_;
  std::vector<bool> layer_ok_;
  std::vector<std::string> interaction_paths_;
  std::vector<ToolSource> tool_sources_;
  std::vector<bool> center_x_given_;
};

// Line and column (1-based) of byte offset `byte` (nlohmann counts the offending byte, 1-based).
std::pair<std::size_t, std::size_t> lineColumn(const std::string& text, std::size_t byte) {
  std::size_t line = 1, column = 1;
  const std::size_t end = std::min(byte > 0 ? byte - 1 : 0, text.size());
  for (std::size_t i = 0; i < end; ++i) {
    if (text[i] == '\n') {
      ++line;
      column = 1;
    } else {
      ++column;
    }
  }
  return {line, column};
}

// Builds the document from nlohmann's SAX events, so that every problem of the text itself gets a
// line, a column and the JSON path where it happened: duplicate keys (nlohmann would keep the last
// one silently), nesting deeper than kMaxNestingDepth (refused before it costs memory), numbers
// outside the double range (1e400) and syntax or UTF-8 errors.
class DocumentBuilder final : public json::json_sax_t {
 public:
  DocumentBuilder(const std::string& text, IssueList& issues) : text_(text), issues_(issues) {}

  json root;

  bool null() override { return add(nullptr); }
  bool boolean(bool v) override { return add(v); }
  bool number_integer(number_integer_t v) override { return add(v); }
  bool number_unsigned(number_unsigned_t v) override { return add(v); }
  bool number_float(number_float_t v, const string_t&) override { return add(v); }
  bool string(string_t& v) override { return add(std::move(v)); }
  bool binary(binary_t&) override { return false; }  // never produced by text JSON
  bool start_object(std::size_t) override { return open(json::object()); }
  bool start_array(std::size_t) override { return open(json::array()); }
  bool end_object() override { return close(); }
  bool end_array() override { return close(); }
  bool key(string_t& key) override {
    Frame& frame = stack_.back();
    if (frame.value->contains(key))
      issues_.add(frame.path + "/" + detail::pointerToken(key), "duplicate key (JSON keeps only the last value)");
    frame.key = key;
    return true;
  }
  bool parse_error(std::size_t position, const std::string&, const nlohmann::detail::exception& error) override {
    const auto [line, column] = lineColumn(text_, position);
    std::string reason = error.what();
    // "[json.exception.parse_error.101] parse error at line 3, column 11: syntax error ..." -> "syntax error ..."
    if (const std::size_t bracket = reason.find("] "); bracket != std::string::npos) reason = reason.substr(bracket + 2);
    if (const std::size_t column_text = reason.find(", column "); reason.rfind("parse error", 0) == 0 &&
                                                                    column_text != std::string::npos)
      reason = reason.substr(reason.find(": ", column_text) + 2);
    if (error.id == 406) reason += " (outside the range of a double)";
    issues_.add(childPath(), "line " + std::to_string(line) + ", column " + std::to_string(column) + ": " + reason);
    return false;
  }

 private:
  struct Frame {
    json* value;
    std::string path;
    std::string key;
  };

  std::string childPath() const {
    if (stack_.empty()) return "";
    const Frame& parent = stack_.back();
    return parent.path + "/" +
           (parent.value->is_object() ? detail::pointerToken(parent.key) : std::to_string(parent.value->size()));
  }
  // Places `value` where the parser is (root, the current key, or the end of the current array).
  json* place(json value) {
    if (stack_.empty()) {
      root = std::move(value);
      return &root;
    }
    Frame& parent = stack_.back();
    if (parent.value->is_object()) {
      json& slot = (*parent.value)[parent.key];
      slot = std::move(value);
      return &slot;
    }
    parent.value->push_back(std::move(value));
    return &parent.value->back();
  }
  bool add(json value) {
    place(std::move(value));
    return true;
  }
  bool open(json container) {
    std::string path = childPath();
    if (stack_.size() >= kMaxNestingDepth) {
      issues_.add(path, "nested deeper than " + std::to_string(kMaxNestingDepth) + " objects and arrays");
      return false;
    }
    json* value = place(std::move(container));
    stack_.push_back({value, std::move(path), {}});
    return true;
  }
  bool close() {
    stack_.pop_back();
    return true;
  }

  const std::string& text_;
  IssueList& issues_;
  std::vector<Frame> stack_;
};

std::optional<json> parseJson(const std::string& text, IssueList& issues) {
  DocumentBuilder builder(text, issues);
  if (!json::sax_parse(text, &builder)) return std::nullopt;
  return std::move(builder.root);
}

}  // namespace

bool hasSoil(StudyKind kind) {
  return kind == StudyKind::Coupled || kind == StudyKind::DemOnly || kind == StudyKind::ConePenetration;
}

Study parseStudy(const std::string& json_text, const std::string& origin) {
  IssueList issues;
  const std::optional<json> root = parseJson(json_text, issues);
  if (!root) throw StudyError(origin, issues.items());
  StudyParser parser(origin, issues);
  Study study = parser.parse(*root);
  if (!issues.empty()) throw StudyError(origin, issues.items());
  return study;
}

Study loadStudy(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  if (!in) throw StudyError(file.string(), {{"", "cannot open the study file"}});
  std::ostringstream text;
  text << in.rdbuf();
  if (!in && !in.eof()) throw StudyError(file.string(), {{"", "cannot read the study file"}});
  return parseStudy(text.str(), file.string());
}

}  // namespace demfem::study

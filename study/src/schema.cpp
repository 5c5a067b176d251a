// The study file's key table (schema.hpp): every leaf key once, with its field, range, need, when
// it applies and its doc line; the generic reader and writer over it; the Markdown key reference.
#include "schema.hpp"

#include "demfem/study/contact_laws.hpp"

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <sstream>
#include <type_traits>

namespace demfem::study::detail {

namespace {

namespace fs = std::filesystem;

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

const Limits kLength = leftOpen(0.0, kMaxLength_mm);
const Limits kDiameter = closedInterval(kMinDiameter_mm, kMaxDiameter_mm);
const Limits kDensity = closedInterval(kMinDensity, kMaxDensity);
const Limits kModulus = closedInterval(kMinModulus_Pa, kMaxModulus_Pa);
const Limits kPoisson = openInterval(-1.0, 0.5);
const Limits kFriction = closedInterval(0.0, kMaxFriction);
const Limits kVelocity = leftOpen(0.0, kMaxVelocity_mm_s);
const Limits kPosition = closedInterval(-kMaxLength_mm, kMaxLength_mm);
const Limits kGain = leftOpen(0.0, 100.0);
const IntegerRange kSeed{0, INT64_MAX};

std::string inQuotes(std::string_view word) { return "\"" + std::string(word) + "\""; }
std::string ticked(std::string_view word) { return "`" + std::string(word) + "`"; }

// "a", "a and b", "a, b and c"
std::string joined(const std::vector<std::string>& words, const std::string& last = " and ") {
  std::string out;
  for (std::size_t i = 0; i < words.size(); ++i) out += (i == 0 ? "" : i + 1 == words.size() ? last : ", ") + words[i];
  return out;
}

// --- when keys apply --------------------------------------------------------------------------

AppliesWhen always() { return {}; }

// A contact parameter: applies to the normal laws whose trait lists it.
AppliesWhen normalLawUses(ContactParameter parameter) {
  std::vector<std::string> names, docs;
  for (NormalModel m : kAllNormalModels) {
    if (!(normalLawParameters(m) & parameter)) continue;
    names.push_back(inQuotes(nameOf(kNormalModels, m)));
    docs.push_back(ticked(nameOf(kNormalModels, m)));
  }
  return {[parameter, models = joined(names)](const KeyContext& c) -> Applies {
            if (!c.normal) return {Applies::Unknown, {}};
            if (normalLawParameters(*c.normal) & parameter) return {};
            return {Applies::No, "only used by contact.normal " + models + ", not " + inQuotes(nameOf(kNormalModels, *c.normal))};
          },
          "`normal` = " + joined(docs, " or ")};
}

AppliesWhen rollingHasFriction() {
  return {[](const KeyContext& c) -> Applies {
            if (!c.rolling) return {Applies::Unknown, {}};
            if (rollingUsesFriction(*c.rolling)) return {};
            return {Applies::No, "soil.contact.rolling is " + inQuotes(nameOf(kRollingModels, *c.rolling))};
          },
          "`rolling` not `none`"};
}

AppliesWhen rollingHasSpinScale() {
  return {[](const KeyContext& c) -> Applies {
            if (!c.rolling) return {Applies::Unknown, {}};
            if (rollingUsesSpinScale(*c.rolling)) return {};
            return {Applies::No, "only used by soil.contact.rolling \"edem-standard\", not " + inQuotes(nameOf(kRollingModels, *c.rolling))};
          },
          "`rolling` = `edem-standard`"};
}

AppliesWhen cohesionHasEnergy() {
  return {[](const KeyContext& c) -> Applies {
            if (!c.cohesion) return {Applies::Unknown, {}};
            if (cohesionUsesEnergyDensity(*c.cohesion)) return {};
            return {Applies::No, "soil.contact.cohesion is " + inQuotes(nameOf(kCohesionModels, *c.cohesion))};
          },
          "`cohesion` not `none`"};
}

AppliesWhen geometryKinds(std::vector<GeometryKind> kinds) {
  std::vector<std::string> names, docs;
  for (GeometryKind k : kinds) {
    names.push_back(inQuotes(nameOf(kGeometryKinds, k)));
    docs.push_back(ticked(nameOf(kGeometryKinds, k)));
  }
  return {[kinds, list = joined(names, ", ")](const KeyContext& c) -> Applies {
            if (!c.geometry) return {Applies::Unknown, {}};
            if (std::find(kinds.begin(), kinds.end(), *c.geometry) != kinds.end()) return {};
            return {Applies::No, "only used by geometry kind " + list};
          },
          "`kind` = " + joined(docs, ", ")};
}

AppliesWhen withSoil() {
  return {[](const KeyContext& c) -> Applies {
            if (hasSoil(c.kind)) return {};
            return {Applies::No, "a " + nameOf(kStudyKinds, c.kind) + " study has no particles to touch the tool"};
          },
          "kinds with soil"};
}

AppliesWhen materialFromFemData() {
  return {[](const KeyContext& c) -> Applies {
            if (c.geometry != GeometryKind::MatrixMarket) return {};
            return {Applies::No, "the mass and stiffness matrices of a \"matrix-market\" geometry already contain it"};
          },
          "`geometry.kind` not `matrix-market`"};
}

AppliesWhen deformableTool(const std::string& reason) {
  return {[reason](const KeyContext& c) -> Applies {
            if (c.deformable) return {};
            return {Applies::No, reason};
          },
          "deformable tools (not `dem-only`)"};
}

AppliesWhen notCone() {
  return {[](const KeyContext& c) -> Applies {
            if (c.geometry != GeometryKind::Cone) return {};
            return {Applies::No, "a cone moves straight down at velocity_mm_s until its tip reaches depth_mm"};
          },
          "not cones"};
}

AppliesWhen criterionStep() {
  return {[](const KeyContext& c) -> Applies {
            if (!c.explicit_dem_step) return {};
            return {Applies::No, "dem.dt_s sets the time step explicitly"};
          },
          "without `dem.dt_s`"};
}

// --- custom fields ----------------------------------------------------------------------------

// `notes`: free text, a string or an array of lines (long explanations stay readable in the file).
CustomField<Study> notesField() {
  return {"string or array of strings",
          [](ObjectReader& o, std::string_view key, Study& study, Need) {
            const nlohmann::json* notes = o.raw(key);
            if (!notes) return true;
            if (notes->is_string()) {
              study.notes = notes->get<std::string>();
              return true;
            }
            if (notes->is_array() &&
                std::all_of(notes->begin(), notes->end(), [](const nlohmann::json& l) { return l.is_string(); })) {
              for (std::size_t i = 0; i < notes->size(); ++i)
                study.notes += (i ? "\n" : "") + (*notes)[i].get<std::string>();
              return true;
            }
            o.report(key, "must be a string or an array of strings, got " + describeValue(*notes));
            return false;
          },
          [](nlohmann::ordered_json& out, std::string_view key, const Study& study) {
            if (!study.notes.empty()) out[std::string(key)] = study.notes;
          }};
}

// interactions[].materials: an unordered pair of material names.
CustomField<Interaction> pairField() {
  return {"two names",
          [](ObjectReader& o, std::string_view key, Interaction& entry, Need need) {
            const nlohmann::json* pair = o.array(key, need);
            if (!pair) return false;
            if (pair->size() == 2 && (*pair)[0].is_string() && (*pair)[1].is_string() &&
                !(*pair)[0].get<std::string>().empty() && !(*pair)[1].get<std::string>().empty()) {
              entry.a = (*pair)[0].get<std::string>();
              entry.b = (*pair)[1].get<std::string>();
              return true;
            }
            o.report(key, "must be an array of two material names, got " + pair->dump());
            return false;
          },
          [](nlohmann::ordered_json& out, std::string_view key, const Interaction& entry) {
            out[std::string(key)] = {entry.a, entry.b};
          }};
}

// --- the generic reader and writer ---------------------------------------------------------

template <class T>
struct KeyReader {
  ObjectReader& o;
  const Key<T>& key;
  T& target;
  Need need;
  const fs::path& base_dir;

  void operator()(double T::*m) const {
    if (auto v = o.quantity(key.name, key.range, need)) target.*m = *v;
  }
  void operator()(std::optional<double> T::*m) const {
    if (auto v = o.quantity(key.name, key.range, need)) target.*m = *v;
  }
  void operator()(int T::*m) const {
    if (auto v = o.integer(key.name, key.integers.min, key.integers.max, need)) target.*m = static_cast<int>(*v);
  }
  void operator()(std::uint64_t T::*m) const {
    if (auto v = o.integer(key.name, key.integers.min, key.integers.max, need)) target.*m = static_cast<std::uint64_t>(*v);
  }
  void operator()(bool T::*m) const {
    if (auto v = o.boolean(key.name, need)) target.*m = *v;
  }
  void operator()(std::string T::*m) const {
    if (auto v = o.string(key.name, need)) target.*m = *v;
  }
  void operator()(fs::path T::*m) const {
    if (auto v = o.string(key.name, need)) target.*m = *v;
  }
  void operator()(const FileField<T>& f) const {
    const std::optional<std::string> name = o.string(key.name, need);
    if (!name) return;
    const fs::path file = fs::absolute(base_dir / fs::path(*name)).lexically_normal();
    std::error_code error;
    if (fs::is_regular_file(file, error))
      target.*f.member = file;
    else
      o.report(key.name, "file not found: " + file.string());
  }
  void operator()(const ChoiceField<T>& f) const {
    NameTable<std::string> words;
    for (const std::string& n : f.names) words.emplace_back(n, n);
    if (auto v = o.choice(key.name, words, need)) f.set(target, *v);
  }
  void operator()(const CustomField<T>& f) const {
    o.known(key.name);
    f.read(o, key.name, target, need);
  }
};

template <class T>
struct KeyWriter {
  nlohmann::ordered_json& out;
  const Key<T>& key;
  const T& source;
  std::string name() const { return std::string(key.name); }

  void operator()(double T::*m) const { out[name()] = fileValue(key.name, source.*m); }
  void operator()(std::optional<double> T::*m) const {
    if (source.*m) out[name()] = fileValue(key.name, *(source.*m));
  }
  void operator()(int T::*m) const { out[name()] = source.*m; }
  void operator()(std::uint64_t T::*m) const { out[name()] = source.*m; }
  void operator()(bool T::*m) const { out[name()] = source.*m; }
  void operator()(std::string T::*m) const {
    if (!(source.*m).empty()) out[name()] = source.*m;
  }
  void operator()(fs::path T::*m) const { out[name()] = (source.*m).string(); }
  void operator()(const FileField<T>& f) const { out[name()] = (source.*f.member).string(); }
  void operator()(const ChoiceField<T>& f) const { out[name()] = f.get(source); }
  void operator()(const CustomField<T>& f) const { f.write(out, key.name, source); }
};

Applies appliesIn(const AppliesWhen& when, const KeyContext& context) {
  return when.test ? when.test(context) : Applies{};
}

// Whether `source` holds the value a default-constructed T has in `field`. Fields written by code
// of their own are never at their default: they cannot be compared.
template <class T>
bool atDefault(const Field<T>& field, const T& source) {
  static const T initial{};
  return std::visit(
      [&](const auto& f) {
        using F = std::decay_t<decltype(f)>;
        if constexpr (std::is_member_object_pointer_v<F>) {
          return source.*f == initial.*f;
        } else if constexpr (std::is_same_v<F, FileField<T>>) {
          return source.*(f.member) == initial.*(f.member);
        } else if constexpr (std::is_same_v<F, ChoiceField<T>>) {
          return f.get(source) == f.get(initial);
        } else {
          return false;
        }
      },
      field);
}

}  // namespace

double fileValue(std::string_view key, double si) {
  char buffer[40];
  std::snprintf(buffer, sizeof buffer, "%.12g", si / siFactorOf(key));
  return std::strtod(buffer, nullptr);
}

template <class T>
void readKeys(ObjectReader& o, const Section<T>& section, T& target, const KeyContext& context,
              const fs::path& base_dir) {
  for (const Key<T>& key : section.keys) {
    const Applies applies = appliesIn(key.applies, context);
    switch (applies.state) {
      case Applies::No:
        o.forbid(key.name, applies.reason);
        break;
      case Applies::Yes:
        std::visit(KeyReader<T>{o, key, target, key.need, base_dir}, key.field);
        break;
      case Applies::Unknown:  // depends on a value that is itself invalid: accepted unjudged
        std::visit(KeyReader<T>{o, key, target, Need::Optional, base_dir}, key.field);
        break;
    }
  }
}

template <class T>
void writeKeys(nlohmann::ordered_json& out, const Section<T>& section, const T& source, const KeyContext& context) {
  for (const Key<T>& key : section.keys) {
    if (appliesIn(key.applies, context).state != Applies::Yes) continue;
    if (context.identity_form && key.identity_omits_default && atDefault(key.field, source)) continue;
    std::visit(KeyWriter<T>{out, key, source}, key.field);
  }
}

// --- the table ----------------------------------------------------------------------------------

const Section<Study>& topSection() {
  static const Section<Study> s{
      "",
      {{"name", &Study::name, Need::Required, {}, {}, always(), {}, "letters, digits, `_ - .`; names output files"},
       {"kind", choice(&Study::kind, kStudyKinds), Need::Required, {}, {}, always(), {}, "what runs (Study kinds)"},
       {"notes", notesField(), Need::Optional, {}, {}, always(), "empty", "free text, one string per paragraph"}}};
  return s;
}

const Section<Soil>& binSection() {
  static const Section<Soil> s{
      "soil.bin",
      {{"length_mm", &Soil::bin_length_m, Need::Required, kLength, {}, always(), {}, "along z (paper: 650)"},
       {"width_mm", &Soil::bin_width_m, Need::Required, kLength, {}, always(), {}, "along x (paper: 250)"},
       {"material", &Soil::bin_material, Need::Required, {}, {}, always(), {}, "DEM material of the bin walls, in `materials`"}}};
  return s;
}

const Section<Soil>& soilSection() {
  static const Section<Soil> s{
      "soil",
      {{"fill_height_mm", &Soil::fill_height_m, Need::Required, kLength, {}, always(), {},
        "settled assembly height (paper: 85), > `diameter_max_mm`"}}};
  return s;
}

const Section<Soil>& particlesSection() {
  static const Section<Soil> s{
      "soil.particles",
      {{"diameter_min_mm", &Soil::diameter_min_m, Need::Required, kDiameter, {}, always(), {},
        "spheres, diameters uniform in [min, max]; <= max"},
       {"diameter_max_mm", &Soil::diameter_max_m, Need::Required, kDiameter, {}, always(), {}, "< the bin's width and length"}}};
  return s;
}

const Section<DemMaterial>& materialSection() {
  static const Section<DemMaterial> s{
      "soil.materials[]",
      {{"name", &DemMaterial::name, Need::Required, {}, {}, always(), {}, "unique; referenced by layers, bin, tools, interactions"},
       {"density_kg_m3", &DemMaterial::density_kg_m3, Need::Required, kDensity, {}, always(), {}, ""},
       {"E_Pa", &DemMaterial::youngs_Pa, Need::Required, kModulus, {}, always(), {},
        "Young's modulus (the shear modulus follows from E and nu)"},
       {"nu", &DemMaterial::poisson, Need::Required, kPoisson, {}, always(), {}, "Poisson's ratio"},
       {"yield_Pa", &DemMaterial::yield_Pa, Need::Required, closedInterval(0.0, kMaxModulus_Pa), {}, always(), {},
        "EDEM hysteretic spring: K1 = 5 R* min(Y_i, Y_j); 0 = not limiting (walls); particle materials need > 0 "
        "with `edem-hysteretic`"}}};
  return s;
}

const Section<ContactModel>& contactSection() {
  static const Section<ContactModel> s{
      "soil.contact",
      {{"normal", choice(&ContactModel::normal, kNormalModels), Need::Required, {}, {}, always(), {}, "normal force law"},
       {"cohesion", choice(&ContactModel::cohesion, kCohesionModels), Need::Required, {}, {}, always(), {},
        "cohesion law (F = k A)"},
       {"rolling", choice(&ContactModel::rolling, kRollingModels), Need::Required, {}, {}, always(), {},
        "rolling resistance law"},
       {"rolling_regularisation_fraction", &ContactModel::rolling_regularisation_fraction, Need::Optional, leftOpen(0.0, 1.0),
        {}, rollingHasSpinScale(), {},
        "the DEM step at this fraction of the stiffest spring's critical step sets the rolling law's spin scale at every "
        "shorter step (docs/builtin-dem.md)",
        true},
       {"tangential_history", &ContactModel::tangential_history, Need::Optional, {}, {}, always(), {},
        "Coulomb friction with a tangential spring (history)"},
       {"stiffness_factor", &ContactModel::stiffness_factor, Need::Required, leftOpen(0.0, 100.0), {},
        normalLawUses(kStiffnessFactor), {}, "Table 2 gamma_t: kt0 = factor x K1 (documented assumption)"},
       {"damping_factor", &ContactModel::damping_factor, Need::Required, closedInterval(0.0, 100.0), {},
        normalLawUses(kDampingFactor), {}, "Table 2 D_n: viscous c = 2 D_n sqrt(m* k) (documented assumption)"},
       {"characteristic_velocity_m_s", &ContactModel::characteristic_velocity_m_s, Need::Required, leftOpen(0.0, 1e4), {},
        normalLawUses(kCharacteristicVelocity), {}, "LIGGGHTS `characteristicVelocity`"},
       {"coefficient_max_elastic_stiffness", &ContactModel::coefficient_max_elastic_stiffness, Need::Required,
        leftOpen(1.0, 1e3), {}, normalLawUses(kCoefficientMaxElasticStiffness), {},
        "LIGGGHTS `coefficientMaxElasticStiffness`"},
       {"coefficient_plasticity_depth", &ContactModel::coefficient_plasticity_depth, Need::Required, leftOpen(0.0, 100.0),
        {}, normalLawUses(kCoefficientPlasticityDepth), {}, "LIGGGHTS `coefficientPlasticityDepth`"},
       {"coefficient_adhesion_stiffness", &ContactModel::coefficient_adhesion_stiffness, Need::Required,
        closedInterval(0.0, 1e3), {}, normalLawUses(kCoefficientAdhesionStiffness), {},
        "LIGGGHTS `coefficientAdhesionStiffness`"}}};
  return s;
}

const Section<Layer>& layerSection() {
  static const Section<Layer> s{
      "soil.layers[]",
      {{"material", &Layer::material, Need::Required, {}, {}, always(), {}, "particle material, not a wall material"},
       {"top_depth_mm", &Layer::top_depth_m, Need::Required, closedInterval(0.0, kMaxLength_mm), {}, always(), {},
        "down from the settled surface; the first layer starts at 0, each where the previous ends"},
       {"bottom_depth_mm", &Layer::bottom_depth_m, Need::Required, kLength, {}, always(), {},
        "> top; the last layer ends at `fill_height_mm`"}}};
  return s;
}

const Section<Interaction>& interactionSection() {
  static const Section<Interaction> s{
      "soil.interactions[]",
      {{"materials", pairField(), Need::Required, {}, {}, always(), {}, "unordered pair of material names"},
       {"restitution", &Interaction::restitution, Need::Required, leftOpen(0.0, 1.0), {}, always(), {},
        "e; the hysteretic spring's K2 = K1 / e^2"},
       {"static_friction", &Interaction::static_friction, Need::Required, kFriction, {}, always(), {}, "Coulomb coefficient"},
       {"rolling_friction", &Interaction::rolling_friction, Need::Required, kFriction, {}, rollingHasFriction(), {},
        "rolling resistance coefficient"},
       {"cohesion_J_m3", &Interaction::cohesion_J_m3, Need::Required, closedInterval(0.0, 1e9), {}, cohesionHasEnergy(),
        {}, "cohesion energy density k"}}};
  return s;
}

const Section<Soil>& depositionSection() {
  static const Section<Soil> s{
      "soil.deposition",
      {{"seed", &Soil::deposition_seed, Need::Optional, {}, kSeed, always(), {}, "random numbers of the gravity deposition"},
       {"settle_kinetic_energy_J", &Soil::settle_kinetic_energy_J, Need::Optional, leftOpen(0.0, 1e6), {}, always(), {},
        "deposition ends below this total kinetic energy"},
       {"bulk_density_kg_m3", &Soil::bulk_density_kg_m3, Need::Optional, kDensity, {}, always(), "the plain gravity pour",
        "the bed's bulk density (particle mass over bin width x length x fill height), reached within 1 % by a "
        "pour with reduced inter-particle friction, the study's friction then restored; built-in deposition only "
        "(docs/builtin-dem.md, \"Soil deposition and reuse\")"},
       {"backend", &Soil::deposition_backend, Need::Optional, {}, {}, always(), {},
        "the DEM backend that deposits the settled soil; every DEM backend starts from that one soil file "
        "(docs/builtin-dem.md, \"Settled soil file\")"},
       {"threads", &Soil::deposition_threads, Need::Optional, {}, {1, kMaxThreads}, always(), {},
        "threads of the built-in deposition; the packing's bits depend on them, so they are part of the soil "
        "hash (a run's own /dem/threads never picks another soil)"},
       {"reload_until_at_rest", &Soil::reload_until_at_rest, Need::Optional, {}, {}, always(), {},
        "the built-in deposition ends by loading the bed as a run loads it until it stays at rest "
        "(docs/builtin-dem.md, \"A bed at rest\"); false: LIGGGHTS' own protocol, pour and settle"}}};
  return s;
}

const Section<Tool>& toolSection() {
  static const Section<Tool> s{
      "tools[]",
      {{"name", &Tool::name, Need::Required, {}, {}, always(), {}, "unique; geometry name on the coupling API"},
       {"dem_material", &Tool::dem_material, Need::Required, {}, {}, withSoil(), {}, "DEM material of the tool's surface"}}};
  return s;
}

const Section<ToolGeometry>& geometrySection() {
  using K = GeometryKind;
  static const Section<ToolGeometry> s{
      "tools[].geometry",
      {{"kind", choice(&ToolGeometry::kind, kGeometryKinds), Need::Required, {}, {}, always(), {},
        "`cone` only (and always) in a `cone-penetration` study"},
       {"length_mm", &ToolGeometry::length_m, Need::Required, kLength, {},
        geometryKinds({K::Plate, K::Gmsh, K::MatrixMarket, K::Cone}), {}, "along tool y (cone: tip to the top of its shaft)"},
       {"width_mm", &ToolGeometry::width_m, Need::Required, kLength, {}, geometryKinds({K::Plate}), {}, "along tool x"},
       {"thickness_mm", &ToolGeometry::thickness_m, Need::Required, kLength, {}, geometryKinds({K::Plate}), {},
        "along tool z"},
       {"mesh_file", FileField<ToolGeometry>{&ToolGeometry::mesh_file}, Need::Required, {}, {}, geometryKinds({K::Gmsh}),
        {}, "Gmsh msh 4 ASCII, must exist"},
       {"mass_file", FileField<ToolGeometry>{&ToolGeometry::mass_file}, Need::Required, {}, {},
        geometryKinds({K::MatrixMarket}), {}, "M, must exist"},
       {"stiffness_file", FileField<ToolGeometry>{&ToolGeometry::stiffness_file}, Need::Required, {}, {},
        geometryKinds({K::MatrixMarket}), {}, "K, must exist"},
       {"keypoint_file", FileField<ToolGeometry>{&ToolGeometry::keypoint_file}, Need::Required, {}, {},
        geometryKinds({K::MatrixMarket}), {}, "keypoint node ids and coordinates, must exist"},
       {"area_mm2", &ToolGeometry::cone_area_m2, Need::Required, leftOpen(0.0, kMaxLength_mm * kMaxLength_mm), {},
        geometryKinds({K::Cone}), {}, "projected area of the cone"},
       {"apex_angle_deg", &ToolGeometry::cone_angle_rad, Need::Required, openInterval(0.0, 180.0), {},
        geometryKinds({K::Cone}), {}, "full apex angle"},
       {"keypoint_spacing_mm", &ToolGeometry::keypoint_spacing_m, Need::Optional, kLength, {},
        geometryKinds({K::Plate, K::Cone}), {}, "surface nodes on this grid are the keypoints (the paper's 5 mm mesh)"}}};
  return s;
}

const Section<ToolFem>& toolFemSection() {
  const std::string rigid = "a rigid tool is not integrated in time (its FEM model gives the load cell's static split)";
  static const Section<ToolFem> s{
      "tools[].fem",
      {{"E_Pa", &ToolFem::youngs_Pa, Need::Required, kModulus, {}, materialFromFemData(), {}, "Young's modulus (Table 3)"},
       {"nu", &ToolFem::poisson, Need::Required, kPoisson, {}, materialFromFemData(), {}, "Poisson's ratio"},
       {"density_kg_m3", &ToolFem::density_kg_m3, Need::Required, kDensity, {}, materialFromFemData(), {}, ""},
       {"element_order", choice(&ToolFem::element_order, kElementOrders), Need::Optional, {}, {}, materialFromFemData(),
        {}, "quadratic hexahedra do not lock in bending"},
       {"alpha_s", &ToolFem::alpha_s, Need::Required, closedInterval(0.0, 1.0), {}, deformableTool(rigid), {},
        "Rayleigh C = alpha K + beta M (Eq 4); Table 3's 0.55 read as 0.55 ms"},
       {"beta_per_s", &ToolFem::beta_per_s, Need::Required, closedInterval(0.0, 1e6), {}, deformableTool(rigid), {},
        "mass-proportional Rayleigh term (Eq 4)"}}};
  return s;
}

const Section<ToolConstraints>& constraintsSection() {
  static const Section<ToolConstraints> s{
      "tools[].constraints",
      {{"clamp_length_mm", &ToolConstraints::clamp_length_m, Need::Required, kLength, {}, always(), {},
        "all DOFs fixed over this top section; < the tool length"},
       {"load_cell_from_top_mm", &ToolConstraints::load_cell_from_top_m, Need::Required, kLength, {}, always(), {},
        "z fixed on this line, below the clamp; its reaction is the measured force"},
       {"sensor_from_top_mm", &ToolConstraints::sensor_from_top_m, Need::Required, kLength, {}, always(), {},
        "deformation sensor point, below the clamp"},
       {"clamp_rotational_stiffness_Nm_per_rad", &ToolConstraints::clamp_rotational_stiffness_Nm_per_rad, Need::Optional,
        leftOpen(0.0, 1e9), {}, deformableTool("the tool is rigid (no FEM model to hold)"), "rigid clamp",
        "a compliant clamp: rotational spring about x at the clamp's lower edge (docs/fem.md)"}}};
  return s;
}

const Section<ToolSensors>& sensorsSection() {
  static const Section<ToolSensors> s{
      "tools[].sensors",
      {{"force_gain", &ToolSensors::force_gain, Need::Optional, kGain, {}, always(), {},
        "load-cell channel gain, reading = gain x true value (physical: 0.8-1.25)"},
       {"deformation_gain", &ToolSensors::deformation_gain, Need::Optional, kGain, {}, always(), {},
        "deformation channel gain (physical: 0.8-1.25)"}}};
  return s;
}

const Section<ToolMotion>& motionSection() {
  static const Section<ToolMotion> s{
      "tools[].motion",
      {{"depth_mm", &ToolMotion::depth_m, Need::Required, kLength, {}, always(), {},
        "working depth of the tip (cone: final tip depth); < `fill_height_mm`, < length - clamp"},
       {"velocity_mm_s", &ToolMotion::velocity_m_s, Need::Required, kVelocity, {}, always(), {},
        "drag velocity (cone: penetration velocity)"},
       {"stroke_mm", &ToolMotion::stroke_m, Need::Required, kLength, {}, notCone(), {}, "drag distance"},
       {"start_z_mm", &ToolMotion::start_z_m, Need::Required, kPosition, {}, always(), {},
        "bin z of the front face at the start of the stroke (cone: of the axis); the path stays in the bin"},
       {"center_x_mm", &ToolMotion::center_x_m, Need::Optional, kPosition, {}, always(), "bin centre line",
        "bin x of the tool's width centre (cone: axis); the tool stays in the bin"},
       {"insertion_velocity_mm_s", &ToolMotion::insertion_velocity_m_s, Need::Required, kVelocity, {}, notCone(), {},
        "vertical insertion speed"}}};
  return s;
}

const Section<WeightDrop>& weightDropSection() {
  static const Section<WeightDrop> s{
      "weight_drop",
      {{"mass_kg", &WeightDrop::mass_kg, Need::Required, leftOpen(0.0, 1e4), {}, always(), {},
        "calibration weight: load on the pan rows plus its mass on M's diagonal (Section 2.10.1)"},
       {"pan_rows_from_tip_mm", &WeightDrop::pan_rows_from_tip_m, Need::Required, kLength, {}, always(), {},
        "keypoint rows within this distance of the tip carry the pan; < the free length"},
       {"duration_s", &WeightDrop::duration_s, Need::Required, leftOpen(0.0, 1e5), {}, always(), {},
        "simulated time, >= `fem.dt_s`"},
       {"added_mass_kg", &WeightDrop::added_mass_kg, Need::Optional, closedInterval(0.0, 1e4), {}, always(), {},
        "mass on the pan rows before the weight is hung (pan, hook, sensor): on M's diagonal, its weight tared (no step load)"}}};
  return s;
}

const Section<FemSettings>& femSection() {
  static const Section<FemSettings> s{
      "fem",
      {{"dt_s", &FemSettings::dt_s, Need::Required, closedInterval(kMinFemStep_s, 1.0), {}, always(), {},
        "Table 3's dt_FEM: the FEM step and coupling interval (force recording interval without FEM)"},
       {"integration", choice(&FemSettings::integration, kFemIntegrations), Need::Optional, {}, {}, always(), {},
        "`modal`: the modes the step feels plus a static correction; `full`: Eq (5) on every DOF (docs/fem.md)"}}};
  return s;
}

const Section<DemSettings>& demSection() {
  static const Section<DemSettings> s{
      "dem",
      {{"backend", &DemSettings::backend, Need::Optional, {}, {}, always(), {}, "a DEM backend or a test backend"},
       {"dt_s", &DemSettings::dt_s, Need::Optional, closedInterval(kMinDemStep_s, 1e-2), {}, always(), "from the criterion",
        "explicit DEM time step"},
       {"criterion", choice(&DemSettings::criterion, kCriteria), Need::Required, {}, {}, criterionStep(), {},
        "critical-step estimate (docs/architecture.md section 11)"},
       {"dt_fraction", &DemSettings::dt_fraction, Need::Required, leftOpen(0.0, 1.0), {}, criterionStep(), {},
        "fraction of the critical step"},
       {"threads", &DemSettings::threads, Need::Optional, {}, {1, kMaxThreads}, always(), "the machine's cores",
        "threads of the built-in DEM (`demfem run --threads N` overrides)"},
       {"seed", &DemSettings::seed, Need::Optional, {}, kSeed, always(), {},
        "random numbers drawn during the run (the deposition has its own)"}}};
  return s;
}

const Section<CouplingSettings>& couplingSection() {
  static const Section<CouplingSettings> s{
      "coupling",
      {{"endpoint", &CouplingSettings::endpoint, Need::Optional, {}, {}, always(), "chosen by `demfem run`",
        "`inproc://`, `ipc://` or `tcp://` address the DEM server listens on"},
       {"force_averaging", choice(&CouplingSettings::force_averaging, kForceAveraging), Need::Optional, {}, {}, always(),
        {}, "node forces: mean over the last interval, or instantaneous (the paper's EDEM choice)"},
       {"timeout_s", &CouplingSettings::timeout_s, Need::Optional, leftOpen(0.0, 86400.0), {}, always(), {},
        "request timeout"},
       {"max_simulate_s", &CouplingSettings::max_simulate_s, Need::Optional, leftOpen(0.0, kMaxSimulateLimitS), {},
        always(), {}, "longest simulate call the DEM server accepts; >= `fem.dt_s`"}}};
  return s;
}

const Section<OutputSettings>& outputSection() {
  static const Section<OutputSettings> s{
      "output",
      {{"directory", &OutputSettings::directory, Need::Optional, {}, {}, always(), "out/<name>",
        "relative to the working directory"},
       {"vtk_every", &OutputSettings::vtk_every, Need::Optional, {}, {0, INT32_MAX}, always(), {},
        "FEM steps between VTK files; 0 = none"},
       {"csv_every", &OutputSettings::csv_every, Need::Optional, {}, {1, INT32_MAX}, always(), {},
        "FEM steps between CSV rows"}}};
  return s;
}

// --- the key reference (docs/study-file.md) -------------------------------------------------

namespace {

template <class T>
struct TypeDoc {
  const Key<T>& key;
  std::string operator()(double T::*) const { return unitOf(key.name); }
  std::string operator()(std::optional<double> T::*) const { return unitOf(key.name); }
  std::string operator()(int T::*) const { return "integer"; }
  std::string operator()(std::uint64_t T::*) const { return "integer"; }
  std::string operator()(bool T::*) const { return "true/false"; }
  std::string operator()(std::string T::*) const { return "string"; }
  std::string operator()(fs::path T::*) const { return "path"; }
  std::string operator()(const FileField<T>&) const { return "file name"; }
  std::string operator()(const ChoiceField<T>& f) const {
    std::vector<std::string> words;
    for (const std::string& n : f.names) words.push_back(ticked(n));
    return joined(words, ", ");
  }
  std::string operator()(const CustomField<T>& f) const { return f.type_doc; }
};

template <class T>
std::string rangeDoc(const Key<T>& key) {
  if (std::holds_alternative<int T::*>(key.field) || std::holds_alternative<std::uint64_t T::*>(key.field))
    return ">= " + std::to_string(key.integers.min) + " and <= " + std::to_string(key.integers.max);
  return key.range.describe();
}

// The default of an optional key: its documented text, or the value a default-constructed T holds.
template <class T>
std::string defaultDoc(const Key<T>& key) {
  if (key.need == Need::Required) return "required";
  if (!key.default_doc.empty()) return key.default_doc;
  nlohmann::ordered_json out = nlohmann::ordered_json::object();
  std::visit(KeyWriter<T>{out, key, T{}}, key.field);
  const auto& v = out.at(std::string(key.name));
  if (v.is_number_float()) return formatNumber(v.get<double>());
  if (v.is_string()) return ticked(v.get<std::string>());
  return v.dump();
}

template <class T>
void addRows(std::ostringstream& out, const Section<T>& section) {
  for (const Key<T>& key : section.keys) {
    const std::string path = section.path.empty() ? std::string(key.name) : section.path + "." + std::string(key.name);
    out << "| `" << path << "` | " << std::visit(TypeDoc<T>{key}, key.field) << " | " << rangeDoc(key) << " | "
        << defaultDoc(key) << " | " << key.applies.doc << " | " << key.doc << " |\n";
  }
}

}  // namespace

std::string keyReferenceTable() {
  std::ostringstream out;
  out << "| key | unit / values | range | default | applies when | meaning |\n"
      << "| --- | --- | --- | --- | --- | --- |\n";
  addRows(out, topSection());
  addRows(out, binSection());
  addRows(out, soilSection());
  addRows(out, particlesSection());
  addRows(out, materialSection());
  addRows(out, contactSection());
  addRows(out, layerSection());
  addRows(out, interactionSection());
  addRows(out, depositionSection());
  addRows(out, toolSection());
  addRows(out, geometrySection());
  addRows(out, toolFemSection());
  addRows(out, constraintsSection());
  addRows(out, sensorsSection());
  addRows(out, motionSection());
  addRows(out, weightDropSection());
  addRows(out, femSection());
  addRows(out, demSection());
  addRows(out, couplingSection());
  addRows(out, outputSection());
  return out.str();
}

#define DEMFEM_STUDY_SECTION_TYPE(T)                                                                             \
  template void readKeys<T>(ObjectReader&, const Section<T>&, T&, const KeyContext&, const fs::path&);         \
  template void writeKeys<T>(nlohmann::ordered_json&, const Section<T>&, const T&, const KeyContext&);
DEMFEM_STUDY_SECTION_TYPE(Study)
DEMFEM_STUDY_SECTION_TYPE(Soil)
DEMFEM_STUDY_SECTION_TYPE(DemMaterial)
DEMFEM_STUDY_SECTION_TYPE(ContactModel)
DEMFEM_STUDY_SECTION_TYPE(Layer)
DEMFEM_STUDY_SECTION_TYPE(Interaction)
DEMFEM_STUDY_SECTION_TYPE(Tool)
DEMFEM_STUDY_SECTION_TYPE(ToolGeometry)
DEMFEM_STUDY_SECTION_TYPE(ToolFem)
DEMFEM_STUDY_SECTION_TYPE(ToolConstraints)
DEMFEM_STUDY_SECTION_TYPE(ToolSensors)
DEMFEM_STUDY_SECTION_TYPE(ToolMotion)
DEMFEM_STUDY_SECTION_TYPE(WeightDrop)
DEMFEM_STUDY_SECTION_TYPE(FemSettings)
DEMFEM_STUDY_SECTION_TYPE(DemSettings)
DEMFEM_STUDY_SECTION_TYPE(CouplingSettings)
DEMFEM_STUDY_SECTION_TYPE(OutputSettings)
#undef DEMFEM_STUDY_SECTION_TYPE

}  // namespace demfem::study::detail

#include "demfem/backends/liggghts/input_deck.hpp"

#include "demfem/adapter/coupling_api.hpp"
#include "demfem/backends/physics/dem_formulas.hpp"
#include "demfem/backends/physics/time_step.hpp"
#include "demfem/study/tool_motion.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <numbers>
#include <optional>
#include <sstream>

namespace demfem::liggghts {
namespace {

using adapter::CouplingError;
using adapter::ErrorCode;

constexpr double kGravity_m_s2 = 9.81;  // along -y

// Values for type pairs that never touch (bin wall against a tool, a tool against another tool).
// LIGGGHTS wants every pair in its tables and rejects a restitution of 0.
constexpr double kNeverTouchingRestitution = 0.5;

// Deposition: particles are inserted at this solid fraction into a slab stack stretched by
// kSettledSolidFraction / kInsertSolidFraction. kSettledSolidFraction is random close packing, the
// densest a random packing of nearly equal spheres settles to, so the settled soil reaches at least
// the fill height and the excess above it is trimmed (frictional packings settle looser: with 0.60
// the quick-study soil ended about 4 mm above a 40 mm fill).
// (Random sequential insertion into thin slabs jams near 0.3: above it insert/pack inserts less.)
constexpr double kInsertSolidFraction = 0.20;
constexpr double kSettledSolidFraction = 0.64;
// A uniform diameter distribution is represented by this many equally likely sizes.
constexpr int kSizeClasses = 5;

std::string num(double value) {
  std::ostringstream out;
  out.precision(17);
  out << value;
  return out.str();
}

bool isPrime(std::uint64_t n) {
  if (n < 2) return false;
  for (std::uint64_t d = 2; d * d <= n; ++d)
    if (n % d == 0) return false;
  return true;
}

// LIGGGHTS wants seeds that are primes above 10000; derive a distinct one per (seed, stream).
std::uint64_t primeSeed(std::uint64_t seed, std::uint64_t stream) {
  std::uint64_t n = 10007 + (seed * 7919 + stream * 104729) % 50000000;
  while (!isPrime(n)) ++n;
  return n;
}

std::string contactModelWords(const study::ContactModel& contact) {
  std::string words = "model ";
  switch (contact.normal) {
    case study::NormalModel::Hooke: words += "hooke"; break;
    case study::NormalModel::HookeHysteresis: words += "hooke/hysteresis"; break;
    case study::NormalModel::EdemHysteretic:
      throw CouplingError(ErrorCode::Unsupported,
                          "soil.contact.normal: the EDEM hysteretic spring (Walton-Braun) does not exist in "
                          "LIGGGHTS-PUBLIC 3.8; use \"hooke\" or \"hooke/hysteresis\" with the liggghts backend "
                          "(docs/liggghts-backend.md)");
  }
  words += contact.tangential_history ? " tangential history" : " tangential no_history";
  switch (contact.cohesion) {
    case study::CohesionModel::None: break;
    case study::CohesionModel::Sjkr: words += " cohesion sjkr"; break;
    case study::CohesionModel::Sjkr2: words += " cohesion sjkr2"; break;
    case study::CohesionModel::EdemLinear:
      throw CouplingError(ErrorCode::Unsupported,
                          "soil.contact.cohesion: the EDEM linear cohesion does not exist in LIGGGHTS-PUBLIC 3.8; "
                          "use \"sjkr\" (exact overlap area) or \"sjkr2\" with the liggghts backend");
  }
  switch (contact.rolling) {
    case study::RollingModel::None: break;
    case study::RollingModel::Cdt: words += " rolling_friction cdt"; break;
    case study::RollingModel::Epsd: words += " rolling_friction epsd"; break;
    case study::RollingModel::EdemStandard:
      throw CouplingError(ErrorCode::Unsupported,
                          "soil.contact.rolling: the EDEM standard rolling friction does not exist in "
                          "LIGGGHTS-PUBLIC 3.8; use \"cdt\" (closest: constant torque) or \"epsd\"");
  }
  return words;
}

// Particle materials (layer order), then the bin material, then the tool materials: one type each.
std::vector<std::string> typeMaterials(const study::Study& study) {
  std::vector<std::string> names;
  auto add = [&names](const std::string& name) {
    if (std::find(names.begin(), names.end(), name) == names.end()) names.push_back(name);
  };
  for (const auto& layer : study.soil.layers) add(layer.material);
  add(study.soil.bin_material);
  for (const auto& tool : study.tools) add(tool.dem_material);
  return names;
}

int typeOf(const std::vector<std::string>& materials, const std::string& name) {
  return static_cast<int>(std::find(materials.begin(), materials.end(), name) - materials.begin()) + 1;
}

bool isParticleMaterial(const study::Study& study, const std::string& name) {
  return std::any_of(study.soil.layers.begin(), study.soil.layers.end(),
                     [&name](const study::Layer& layer) { return layer.material == name; });
}

std::optional<study::Interaction> interactionOf(const study::Study& study, const std::string& a,
                                                const std::string& b) {
  try {
    return study.interaction(a, b);
  } catch (const std::out_of_range&) {
    if (isParticleMaterial(study, a) || isParticleMaterial(study, b))
      throw CouplingError(ErrorCode::BadRequest, "soil.interactions: no entry for the material pair \"" + a +
                                                     "\" / \"" + b + "\", which particles touch");
    return std::nullopt;
  }
}

// One `fix property/global NAME peratomtypepair N v11 v12 ...` line from a per-interaction value.
template <typename Value>
std::string pairTable(const study::Study& study, const std::vector<std::string>& materials,
                      const std::string& fix_id, const std::string& property, Value value,
                      double never_touching) {
  const auto n = materials.size();
  std::string line = "fix " + fix_id + " all property/global " + property + " peratomtypepair " + std::to_string(n);
  for (const auto& a : materials)
    for (const auto& b : materials) {
      const auto interaction = interactionOf(study, a, b);
      line += ' ';  // (" " + num(...) trips GCC 12's false -Wrestrict positive)
      line += num(interaction ? value(*interaction) : never_touching);
    }
  return line;
}

std::string uniformPairTable(std::size_t n, const std::string& fix_id, const std::string& property, double value) {
  std::string line = "fix " + fix_id + " all property/global " + property + " peratomtypepair " + std::to_string(n);
  for (std::size_t k = 0; k < n * n; ++k) {
    line += ' ';
    line += num(value);
  }
  return line;
}

void requirePositive(double value, const std::string& where) {
  if (!(value > 0) || !std::isfinite(value))
    throw CouplingError(ErrorCode::BadRequest, where + " must be a positive number for LIGGGHTS (got " + num(value) + ")");
}

// Checks what would make LIGGGHTS stop the process instead of reporting an error.
void validateForLiggghts(const study::Study& study, const std::vector<std::string>& materials) {
  if (study.soil.layers.empty()) throw CouplingError(ErrorCode::BadRequest, "soil.layers: at least one layer is needed");
  requirePositive(study.soil.bin_length_m, "soil.bin_length_m");
  requirePositive(study.soil.bin_width_m, "soil.bin_width_m");
  requirePositive(study.soil.fill_height_m, "soil.fill_height_m");
  requirePositive(study.soil.diameter_min_m, "soil.diameter_min_m");
  if (study.soil.diameter_max_m < study.soil.diameter_min_m)
    throw CouplingError(ErrorCode::BadRequest, "soil.diameter_max_m is below soil.diameter_min_m");
  for (const auto& name : materials) {
    const study::DemMaterial* material = nullptr;
    try {
      material = &study.material(name);
    } catch (const std::out_of_range&) {
      throw CouplingError(ErrorCode::BadRequest, "soil.materials: material \"" + name + "\" is used but not defined");
    }
    requirePositive(material->youngs_Pa, "soil.materials[" + name + "].E_Pa");
    if (!(material->poisson >= 0 && material->poisson < 0.5))
      throw CouplingError(ErrorCode::BadRequest, "soil.materials[" + name + "].poisson must lie in [0, 0.5)");
    if (isParticleMaterial(study, name)) requirePositive(material->density_kg_m3, "soil.materials[" + name + "].density");
  }
  for (const auto& a : materials)
    for (const auto& b : materials)
      if (const auto interaction = interactionOf(study, a, b)) {
        const std::string where = "soil.interactions[" + a + "/" + b + "]";
        if (!(interaction->restitution > 0 && interaction->restitution <= 1))
          throw CouplingError(ErrorCode::BadRequest, where + ".restitution must lie in (0, 1] for LIGGGHTS");
        if (interaction->static_friction < 0 || interaction->rolling_friction < 0 || interaction->cohesion_J_m3 < 0)
          throw CouplingError(ErrorCode::BadRequest, where + ": friction and cohesion must not be negative");
      }
  const auto& contact = study.soil.contact;
  requirePositive(contact.characteristic_velocity_m_s, "soil.contact.characteristic_velocity_m_s");
  if (contact.normal == study::NormalModel::HookeHysteresis) {
    if (!(contact.coefficient_max_elastic_stiffness > 1))
      throw CouplingError(ErrorCode::BadRequest,
                          "soil.contact.coefficient_max_elastic_stiffness must exceed 1 for hooke/hysteresis");
    requirePositive(contact.coefficient_plasticity_depth, "soil.contact.coefficient_plasticity_depth");
  }
  for (std::size_t i = 0; i < study.tools.size(); ++i) {
    const auto& tool = study.tools[i];
    const std::string where = "tools[" + std::to_string(i) + "]";
    if (tool.geometry.kind != study::GeometryKind::Plate && tool.geometry.kind != study::GeometryKind::Cone)
      throw CouplingError(ErrorCode::Unsupported,
                          where + ".geometry: the liggghts backend builds plate and cone tools only (keypoint surface)");
    requirePositive(tool.motion.depth_m, where + ".motion.depth_m");
  }
}

}  // namespace

int atomType(const study::Study& study, const std::string& material) {
  const auto materials = typeMaterials(study);
  if (std::find(materials.begin(), materials.end(), material) == materials.end())
    throw CouplingError(ErrorCode::BadRequest, "material \"" + material + "\" is not used by the study's layers, bin or tools");
  return typeOf(materials, material);
}

adapter::ToolSurface toolSurface(const study::Study& study, std::size_t tool_index) {
  try {
    return adapter::toolSurface(study.tools.at(tool_index));
  } catch (const std::invalid_argument& e) {
    throw CouplingError(ErrorCode::Unsupported, "tools[" + std::to_string(tool_index) + "].geometry: " + e.what());
  }
}

std::array<double, 3> toolStartOrigin(const study::Study& study, std::size_t tool_index) {
  return study::planToolMotion(study, study.tools.at(tool_index)).start_m;
}

void writeToolStl(const adapter::ToolSurface& surface, const std::array<double, 3>& origin,
                  const std::filesystem::path& file) {
  std::ofstream out(file);
  if (!out) throw CouplingError(ErrorCode::Internal, "cannot write the tool surface file " + file.string());
  out.precision(17);
  out << "solid tool\n";
  for (const auto& tri : surface.triangles) {
    std::array<std::array<double, 3>, 3> p{};
    for (int k = 0; k < 3; ++k)
      for (int c = 0; c < 3; ++c) p[k][c] = surface.nodes[static_cast<std::size_t>(tri[k])][c] + origin[c];
    const std::array<double, 3> e1{p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]};
    const std::array<double, 3> e2{p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]};
    std::array<double, 3> n{e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    const double len = std::hypot(n[0], n[1], n[2]);
    out << " facet normal " << n[0] / len << ' ' << n[1] / len << ' ' << n[2] / len << "\n  outer loop\n";
    for (const auto& v : p) out << "   vertex " << v[0] << ' ' << v[1] << ' ' << v[2] << '\n';
    out << "  endloop\n endfacet\n";
  }
  out << "endsolid tool\n";
  if (!out) throw CouplingError(ErrorCode::Internal, "writing the tool surface file " + file.string() + " failed");
}

InputDeck translateStudy(const study::Study& study, const std::filesystem::path& stl_dir) {
  const auto materials = typeMaterials(study);
  validateForLiggghts(study, materials);
  const auto& soil = study.soil;
  const auto& contact = soil.contact;
  const std::string model = contactModelWords(contact);
  const std::size_t n_types = materials.size();

  InputDeck deck;
  deck.atom_type_count = static_cast<int>(n_types);
  deck.time_step_s = study::demStepDividing(physics::demTimeStep(study).step_s, study.fem.dt_s);  // one clock with the FEM

  const double w = soil.bin_width_m;
  const double r_max = soil.diameter_max_m / 2;
  const double stretch = kSettledSolidFraction / kInsertSolidFraction;
  const double insertion_top_m = stretch * soil.fill_height_m + soil.diameter_max_m;
  deck.fall_time_s = std::sqrt(2 * insertion_top_m / kGravity_m_s2);

  // Box: the bin, the insertion stack and every tool over its whole stroke (a mesh element outside
  // the box is a fatal LIGGGHTS error), with a margin.
  double z_lo = 0, z_hi = soil.bin_length_m, y_hi = insertion_top_m, x_lo = 0, x_hi = w;
  for (std::size_t i = 0; i < study.tools.size(); ++i) {
    const auto& tool = study.tools[i];
    const auto origin = toolStartOrigin(study, i);
    const auto surface = toolSurface(study, i);
    const double depth_z = surface.hi[2] - surface.lo[2];
    z_lo = std::min(z_lo, origin[2] + surface.lo[2] - 0.5 * depth_z);
    z_hi = std::max(z_hi, origin[2] + tool.motion.stroke_m + surface.hi[2] + 1.5 * depth_z);
    y_hi = std::max(y_hi, origin[1] + surface.hi[1]);
    x_lo = std::min(x_lo, origin[0] + surface.lo[0]);
    x_hi = std::max(x_hi, origin[0] + surface.hi[0]);
  }
  const double margin = 0.1 * std::max(soil.bin_length_m, y_hi) + 4 * r_max;
  auto& s = deck.setup;
  s.push_back("atom_style granular");
  s.push_back("atom_modify map array");
  s.push_back("boundary f f f");
  s.push_back("newton off");
  s.push_back("communicate single vel yes");
  s.push_back("units si");
  s.push_back("processors 1 1 *");  // slabs along the bin (z), the long axis
  s.push_back("region domain block " + num(x_lo - margin) + " " + num(x_hi + margin) + " " + num(-margin) + " " +
              num(y_hi + margin) + " " + num(z_lo - margin) + " " + num(z_hi + margin) + " units box");
  s.push_back("create_box " + std::to_string(n_types) + " domain");
  // LIGGGHTS refuses Young's moduli above 1 GPa in SI units unless told the particles are hard.
  if (std::any_of(materials.begin(), materials.end(),
                  [&study](const std::string& name) { return study.material(name).youngs_Pa > 1e9; }))
    s.push_back("hard_particles yes");
  s.push_back("neighbor " + num(0.25 * soil.diameter_max_m) + " bin");
  s.push_back("neigh_modify delay 0");

  // Materials: per type, then per type pair (Table 2 restitution and cohesion, Table 4 friction).
  std::string youngs = "fix m_E all property/global youngsModulus peratomtype";
  std::string poisson = "fix m_nu all property/global poissonsRatio peratomtype";
  for (const auto& name : materials) {
    youngs += " " + num(study.material(name).youngs_Pa);
    poisson += " " + num(study.material(name).poisson);
  }
  s.push_back(youngs);
  s.push_back(poisson);
  s.push_back(pairTable(study, materials, "m_e", "coefficientRestitution",
                        [](const study::Interaction& i) { return i.restitution; }, kNeverTouchingRestitution));
  s.push_back(pairTable(study, materials, "m_mu", "coefficientFriction",
                        [](const study::Interaction& i) { return i.static_friction; }, 0.0));
  s.push_back("fix m_v all property/global characteristicVelocity scalar " + num(contact.characteristic_velocity_m_s));
  if (contact.rolling != study::RollingModel::None)
    s.push_back(pairTable(study, materials, "m_mur", "coefficientRollingFriction",
                          [](const study::Interaction& i) { return i.rolling_friction; }, 0.0));
  if (contact.rolling == study::RollingModel::Epsd)
    s.push_back(uniformPairTable(n_types, "m_etar", "coefficientRollingViscousDamping", contact.damping_factor));
  if (contact.cohesion != study::CohesionModel::None)
    s.push_back(pairTable(study, materials, "m_coh", "cohesionEnergyDensity",
                          [](const study::Interaction& i) { return i.cohesion_J_m3; }, 0.0));
  if (contact.normal == study::NormalModel::HookeHysteresis) {
    s.push_back(uniformPairTable(n_types, "m_k2", "coefficientMaxElasticStiffness",
                                 contact.coefficient_max_elastic_stiffness));
    s.push_back(uniformPairTable(n_types, "m_kc", "coefficientAdhesionStiffness",
                                 contact.coefficient_adhesion_stiffness));
    s.push_back(uniformPairTable(n_types, "m_phi", "coefficientPlasticityDepth", contact.coefficient_plasticity_depth));
  }
  s.push_back("pair_style gran " + model);
  s.push_back("pair_coeff * *");
  s.push_back("timestep " + num(deck.time_step_s));
  s.push_back("fix gravity all gravity " + num(kGravity_m_s2) + " vector 0 -1 0");

  // Bin: floor, side walls and end walls as primitive planes of the bin material.
  const std::string wall = "all wall/gran " + model + " primitive type " +
                           std::to_string(typeOf(materials, soil.bin_material));
  s.push_back("fix bin_floor " + wall + " yplane 0");
  s.push_back("fix bin_x_lo " + wall + " xplane 0");
  s.push_back("fix bin_x_hi " + wall + " xplane " + num(w));
  s.push_back("fix bin_z_lo " + wall + " zplane 0");
  s.push_back("fix bin_z_hi " + wall + " zplane " + num(soil.bin_length_m));

  s.push_back("compute kinetic_energy all ke");
  s.push_back("compute rotational_energy all erotate/sphere");
  s.push_back("thermo_style custom step atoms c_kinetic_energy c_rotational_energy");
  s.push_back("thermo_modify lost ignore norm no");  // after thermo_style, which resets it
  s.push_back("thermo 100000");

  // Deposition: per layer, kSizeClasses equally likely diameters spanning [d_min, d_max].
  auto& d = deck.deposition;
  const double dd = (soil.diameter_max_m - soil.diameter_min_m) / kSizeClasses;
  const int classes = dd > 0 ? kSizeClasses : 1;
  // The slabs stop r_max short of the walls; scale the fraction so the bin as a whole gets it.
  const double area_scale = (soil.bin_width_m * soil.bin_length_m) /
                            ((soil.bin_width_m - 2 * r_max) * (soil.bin_length_m - 2 * r_max));
  for (std::size_t l = 0; l < soil.layers.size(); ++l) {
    const auto& layer = soil.layers[l];
    const int type = typeOf(materials, layer.material);
    const std::string tag = "layer" + std::to_string(l);
    std::string distribution = "fix " + tag + "_sizes all particledistribution/discrete/numberbased " +
                               std::to_string(primeSeed(soil.deposition_seed, 3 * l)) + " " + std::to_string(classes);
    for (int k = 0; k < classes; ++k) {
      const double diameter = soil.diameter_min_m + (k + 0.5) * dd;
      const std::string id = tag + "_size" + std::to_string(k);
      d.push_back("fix " + id + " all particletemplate/sphere " +
                  std::to_string(primeSeed(soil.deposition_seed, 3 * l + 1 + 1000 * (k + 1))) + " atom_type " +
                  std::to_string(type) + " density constant " + num(study.material(layer.material).density_kg_m3) +
                  " radius constant " + num(diameter / 2));
      distribution += " " + id + " " + num(1.0 / classes);
    }
    d.push_back(distribution);
    const double y_lo = stretch * (soil.fill_height_m - layer.bottom_depth_m);
    const double y_hi_layer = stretch * (soil.fill_height_m - layer.top_depth_m);
    d.push_back("region " + tag + "_slab block " + num(r_max) + " " + num(w - r_max) + " " +
                num(y_lo + r_max) + " " + num(y_hi_layer + r_max) + " " + num(r_max) + " " +
                num(soil.bin_length_m - r_max) + " units box");
    d.push_back("fix " + tag + "_insert all insert/pack seed " +
                std::to_string(primeSeed(soil.deposition_seed, 3 * l + 2)) + " distributiontemplate " + tag +
                "_sizes insert_every once overlapcheck yes all_in yes volumefraction_region " +
                num(std::min(0.25, kInsertSolidFraction * area_scale)) + " region " + tag + "_slab");
  }
  // After settling: particles whose centre lies above the fill height are removed, as the built-in
  // backend does, so that the tool depth (measured from the fill height) cuts the same soil.
  deck.trim.push_back("region above_fill block INF INF " + num(soil.fill_height_m) + " INF INF INF units box");
  deck.trim.push_back("delete_atoms region above_fill compress yes");
  // Room for the tools: particles within r_max of a tool's start position are removed before the
  // tool's mesh appears (the tool is inserted into the settled soil).
  for (std::size_t i = 0; i < study.tools.size(); ++i) {
    const auto surface = toolSurface(study, i);
    const auto origin = toolStartOrigin(study, i);
    const std::string id = "tool" + std::to_string(i) + "_space";
    std::string block;
    for (int c = 0; c < 3; ++c) block += " " + num(origin[c] + surface.lo[c] - r_max) + " " + num(origin[c] + surface.hi[c] + r_max);
    deck.tool_clearance.push_back("region " + id + " block" + block + " units box");
    deck.tool_clearance.push_back("delete_atoms region " + id + " compress yes");
  }
  // Tools: one stress mesh each, a single mesh wall over all of them, a variable-velocity mover.
  auto& t = deck.tools;
  if (!study.tools.empty()) {
    std::string meshes;
    for (std::size_t i = 0; i < study.tools.size(); ++i) {
      const std::string id = "tool" + std::to_string(i);
      t.push_back("fix " + id + " all mesh/surface/stress file " + (stl_dir / (id + ".stl")).string() + " type " +
                  std::to_string(typeOf(materials, study.tools[i].dem_material)));
      meshes += " " + id;
    }
    t.push_back("fix tool_wall all wall/gran " + model + " mesh n_meshes " + std::to_string(study.tools.size()) +
                " meshes" + meshes + " store_force_contact_stress yes");
    for (std::size_t i = 0; i < study.tools.size(); ++i) {
      const std::string id = "tool" + std::to_string(i);
      for (const char* c : {"_vx", "_vy", "_vz"}) t.push_back("variable " + id + c + " equal 0");
      t.push_back("fix " + id + "_move all move/mesh mesh " + id + " linear/variable v_" + id + "_vx v_" + id +
                  "_vy v_" + id + "_vz");
    }
  }
  return deck;
}

}  // namespace demfem::liggghts

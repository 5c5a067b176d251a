// demfem study: the in-memory form of one study file (studies/*.json), docs/architecture.md section 7.
//
// Contract
// - Every quantity is SI inside (m, s, kg, N, Pa, rad). The JSON file carries the unit in the key
//   name (`depth_mm`, `E_Pa`, `alpha_s`); the loader converts once, here nothing is in mm.
// - A Study returned by loadStudy() has passed validation (validate() applies the same gate to a
//   study built in code): every field has the documented type,
//   unit and range, cross-field rules hold (layers tile the bin depth, the interaction table covers
//   every material pair, constraints lie on the tool). Code using a Study may rely on that.
// - Frames (docs/architecture.md section 10): bin frame x across, y up (y = 0 bin floor), z along the bin, with
//   the origin at a bottom corner so the soil fills x in [0, bin_width], z in [0, bin_length]; tool
//   local frame x across the width, y along the length (tip y = 0, top y = L), z the travel direction
//   (through the thickness), origin at the tip, centred in x and z. The tool moves in +z of the bin
//   frame.
// - The file format (every key, unit, range and default) is documented in docs/study-file.md.
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <numbers>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace demfem::study {

// One validation problem: where (JSON pointer, e.g. "/tools/0/fem/E_Pa"; empty = the whole file,
// e.g. a syntax error whose message gives line and column) and what.
struct Issue {
  std::string path;
  std::string message;
  bool operator==(const Issue&) const = default;
};

// Thrown by loadStudy()/parseStudy() with every problem found, not just the first. what() lists them
// as "FILE: PATH: MESSAGE" lines ("FILE: MESSAGE" when the path is empty). File, paths and messages
// are valid UTF-8 (bytes that are not are written as \xNN).
class StudyError : public std::runtime_error {
 public:
  StudyError(std::string file, std::vector<Issue> issues);
  const std::string& file() const { return file_; }
  const std::vector<Issue>& issues() const { return issues_; }

 private:
  std::string file_;
  std::vector<Issue> issues_;
};

// Elastic and contact properties of a DEM material (particles of a layer, bin walls, a tool).
struct DemMaterial {
  std::string name;
  double density_kg_m3 = 0;
  double youngs_Pa = 0;
  double poisson = 0;
  double yield_Pa = 0;  // EDEM hysteretic spring: K1 = 5 R* min(Y_i, Y_j); 0 = not limiting (walls)
  bool operator==(const DemMaterial&) const = default;
};

// Contact law selection (docs/architecture.md section 11). EDEM-style and LIGGGHTS-compatible variants.
enum class NormalModel { EdemHysteretic, Hooke, HookeHysteresis };
enum class CohesionModel { None, EdemLinear, Sjkr, Sjkr2 };
enum class RollingModel { None, EdemStandard, Cdt, Epsd };

struct ContactModel {
  NormalModel normal = NormalModel::EdemHysteretic;
  CohesionModel cohesion = CohesionModel::EdemLinear;
  RollingModel rolling = RollingModel::EdemStandard;
  bool tangential_history = true;
  // EDEM "stiffness factor" (Table 2 gamma_t): kt0 = stiffness_factor * K1 (documented assumption).
  double stiffness_factor = 0.85;
  // EDEM "damping factor" (Table 2 D_n): viscous c = 2 D_n sqrt(m* k) (documented assumption).
  double damping_factor = 0.5;
  // edem-standard rolling: the DEM step at this fraction of the stiffest spring's critical step sets
  // the law's spin scale at every shorter step, so that below it the law no longer changes with the
  // step (physics::rollingRegularisationStep, docs/builtin-dem.md "Rolling friction at rest").
  double rolling_regularisation_fraction = 0.025;
  // LIGGGHTS hooke / hooke/hysteresis parameters (LIGGGHTS 3.8 names).
  double characteristic_velocity_m_s = 0.1;
  double coefficient_max_elastic_stiffness = 2.0;
  double coefficient_plasticity_depth = 0.1;
  double coefficient_adhesion_stiffness = 0.0;
  bool operator==(const ContactModel&) const = default;
};

// Interaction between two materials (symmetric): Table 2 restitution/cohesion, Table 4 friction.
struct Interaction {
  std::string a, b;  // material names
  double restitution = 0.5;
  double static_friction = 0.5;
  double rolling_friction = 0.0;
  double cohesion_J_m3 = 0.0;
  bool operator==(const Interaction&) const = default;
};

// A horizontal soil layer, depth measured down from the settled soil surface (Section 2.9, Fig. 4a).
struct Layer {
  std::string material;  // DemMaterial name of the particles in this layer
  double top_depth_m = 0;
  double bottom_depth_m = 0;
  bool operator==(const Layer&) const = default;
};

struct Soil {
  double bin_length_m = 0.650;  // along z
  double bin_width_m = 0.250;   // along x
  double fill_height_m = 0.085; // settled assembly height, y
  double diameter_min_m = 0.0095;
  double diameter_max_m = 0.0105;
  std::vector<DemMaterial> materials;      // particle materials and wall materials
  std::string bin_material;                // DemMaterial name of the bin walls
  std::vector<Layer> layers;               // top to bottom, tiling 0..fill_height
  std::vector<Interaction> interactions;   // every pair of used materials, incl. walls and tools
  ContactModel contact;
  std::uint64_t deposition_seed = 1;
  double settle_kinetic_energy_J = 1e-6;   // deposition ends below this total kinetic energy
  // The bed's measured bulk density (soil.deposition.bulk_density_kg_m3, kg/m^3: particle mass over
  // bin width x length x fill height, what a core sampler gives). Set: the built-in deposition pours
  // with reduced inter-particle friction until the bed reaches it within 1 %, then restores the
  // study's friction and settles (docs/builtin-dem.md, "Soil deposition and reuse"); unset: the
  // plain gravity pour.
  std::optional<double> bulk_density_kg_m3;
  // The DEM backend that deposits the settled soil (soil.deposition.backend, a name of the backend
  // registry, study/backend_capabilities.hpp): every DEM backend starts from that one settled soil
  // (the backend-neutral file of adapter/settled_soil.hpp).
  std::string deposition_backend = "builtin";
  // Threads of the built-in deposition (soil.deposition.threads): the packing's bits depend on them,
  // so they enter the soil hash, and a run's own thread count never picks another soil.
  int deposition_threads = 1;
  // soil.deposition.reload_until_at_rest: the built-in deposition ends with the reload phase (the
  // bed loaded as a run loads it until it is at rest, docs/builtin-dem.md, "A bed at rest"); off,
  // the protocol is LIGGGHTS' own (pour and settle), for like-for-like comparisons with it.
  bool reload_until_at_rest = true;
  bool operator==(const Soil&) const = default;
};

// Tool geometry: a plate meshed by demfem, a Gmsh mesh, or externally assembled M and K.
enum class GeometryKind { Plate, Gmsh, MatrixMarket, Cone };

struct ToolGeometry {
  GeometryKind kind = GeometryKind::Plate;
  double length_m = 0.200;    // plate: along tool y
  double width_m = 0.040;     // plate: along tool x
  double thickness_m = 0.003; // plate: along tool z
  double keypoint_spacing_m = 0.005;   // DEM grid: surface nodes on this grid are the keypoints
  std::filesystem::path mesh_file;     // Gmsh: msh 4 ASCII
  std::filesystem::path mass_file;     // MatrixMarket: M
  std::filesystem::path stiffness_file;// MatrixMarket: K
  std::filesystem::path keypoint_file; // MatrixMarket: keypoint list (node ids and coordinates)
  // Cone penetrometer (Fig. 6c): projected area and full apex angle; length_m is tip to shaft top
  // (the shaft is a cylinder of the cone's base radius).
  double cone_area_m2 = 5e-4;
  double cone_angle_rad = 1.0471975511965976;
  double coneRadius_m() const { return std::sqrt(cone_area_m2 / std::numbers::pi); }      // base = shaft radius
  double coneHeight_m() const { return coneRadius_m() / std::tan(cone_angle_rad / 2); }   // tip to base
  bool operator==(const ToolGeometry&) const = default;
};

enum class ElementOrder { Linear, Quadratic };

struct ToolFem {
  bool deformable = true;        // false: rigid tool, DEM only (the paper's S235 "DEM simulation")
  double youngs_Pa = 0;
  double poisson = 0;
  double density_kg_m3 = 0;
  // Rayleigh damping C = alpha K + beta M (Eq 4). alpha in seconds: Table 3's 0.55 read as 0.55 ms.
  double alpha_s = 0;
  double beta_per_s = 0;
  ElementOrder element_order = ElementOrder::Quadratic;
  bool operator==(const ToolFem&) const = default;
};

// Section 2.9 constraints, measured from the top of the tool (y = L) downwards.
struct ToolConstraints {
  double clamp_length_m = 0.040;       // all DOF fixed for y >= L - clamp_length
  double load_cell_from_top_m = 0.065; // z fixed on this line
  double sensor_from_top_m = 0.093;    // deformation sensor point
  // A compliant clamp: a rotational spring (N m/rad, for the whole width) about the x axis at the
  // clamp's lower edge instead of the rigid clamp. Absent = rigid clamp (docs/fem.md).
  std::optional<double> clamp_rotational_stiffness_Nm_per_rad;
  bool operator==(const ToolConstraints&) const = default;
};

// Gains of the two measured channels (reading = gain x true value): 1 = ideal sensors. They model a
// calibration-factor error of the load cell or the deformation sensor (docs/fem.md, Sensors).
struct ToolSensors {
  double force_gain = 1.0;
  double deformation_gain = 1.0;
  bool operator==(const ToolSensors&) const = default;
};

// Rigid motion in the bin frame: inserted vertically to `depth`, then dragged in +z. The motion a
// run follows is computed from these by planToolMotion() (tool_motion.hpp).
struct ToolMotion {
  double depth_m = 0.018;
  double velocity_m_s = 0.03119;
  double stroke_m = 0.600;
  // Bin z of the tool's front (soil-engaging) face, local z = +T/2, at the start of the stroke; for a
  // cone, of its axis.
  double start_z_m = 0.0;
  double insertion_velocity_m_s = 0.05; // vertical insertion before the stroke
  double center_x_m = 0.125;       // bin x of the tool's width centre / cone axis (file default: bin centre)
  bool operator==(const ToolMotion&) const = default;
};

struct Tool {
  std::string name = "tool";       // geometry name on the coupling API
  std::string dem_material;        // DemMaterial name used for particle-tool contacts
  ToolGeometry geometry;
  ToolFem fem;
  ToolConstraints constraints;
  ToolSensors sensors;             // deformable tools only
  ToolMotion motion;
  bool operator==(const Tool&) const = default;
};

// Calibration-weight test (Section 2.10.1, Fig. 5): tool clamped horizontally, weight hung suddenly.
struct WeightDrop {
  double mass_kg = 1.0;
  double pan_rows_from_tip_m = 0.010;  // keypoint rows within this distance of the tip carry the pan
  double duration_s = 3.0;
  // Mass on the pan rows present before the weight is hung (pan, hook, a sensor): on M's diagonal,
  // its weight tared with the tool's, so it is not part of the step load (docs/study-file.md).
  double added_mass_kg = 0.0;
  bool operator==(const WeightDrop&) const = default;
};

// How the reduced tool model is integrated in time (fem/modal.hpp): in modal coordinates with the
// modes the FEM step resolves and a static correction (default), or the full three-level form.
enum class FemIntegration { Modal, Full };

struct FemSettings {
  double dt_s = 0.001;            // Table 3 dt_FEM
  FemIntegration integration = FemIntegration::Modal;  // key fem.integration: "modal" | "full"
  bool operator==(const FemSettings&) const = default;
};

enum class TimeStepCriterion { Rayleigh, StiffestSpring };

struct DemSettings {
  std::string backend = "builtin";   // a backend of this build (study::backendIssues checks it)
  TimeStepCriterion criterion = TimeStepCriterion::Rayleigh;
  double dt_fraction = 0.2;          // of the chosen criterion's critical step
  std::optional<double> dt_s;        // explicit step, overrides the criterion
  int threads = 1;                // a study file without dem.threads gets the machine's cores (loadStudy)
  std::uint64_t seed = 1;             // draws during the run; deposition: soil.deposition_seed
  bool operator==(const DemSettings&) const = default;
};

enum class ForceAveraging { IntervalMean, Instantaneous };

// Longest simulated time one simulate call may ask of a DEM server, unless the study raises it:
// 1000 FEM steps of the paper's 1 ms.
inline constexpr double kDefaultMaxSimulateS = 1.0;
// The most DEM steps a study may take over its simulated time, whichever key sets the step
// (`dem.dt_s` here, `dem.dt_fraction` where the critical step is known: cli::loadCheckedStudy).
inline constexpr double kMaxDemSteps = 1e11;

struct CouplingSettings {
  std::string endpoint;              // empty: chosen by `demfem run` (ipc://)
  ForceAveraging force_averaging = ForceAveraging::IntervalMean;
  double timeout_s = 30.0;
  double max_simulate_s = kDefaultMaxSimulateS;
  bool operator==(const CouplingSettings&) const = default;
};

struct OutputSettings {
  std::filesystem::path directory = "out";
  int vtk_every = 0;                 // FEM steps between VTK files; 0 = none
  int csv_every = 1;
  bool operator==(const OutputSettings&) const = default;
};

enum class StudyKind { Coupled, DemOnly, WeightDrop, ConePenetration, FemOnly };

struct Study {
  std::filesystem::path source;      // file it was loaded from (empty if built in code)
  std::string name;
  StudyKind kind = StudyKind::Coupled;
  std::string notes;
  Soil soil;
  std::vector<Tool> tools;
  std::optional<WeightDrop> weight_drop;
  FemSettings fem;
  DemSettings dem;
  CouplingSettings coupling;
  OutputSettings output;

  const DemMaterial& material(const std::string& name) const;  // throws std::out_of_range
  // The entry for the unordered pair {a, b}; throws std::out_of_range if the table has none.
  const Interaction& interaction(const std::string& a, const std::string& b) const;

  bool operator==(const Study&) const = default;
};

// Loads and validates a study file. Throws StudyError listing every problem (with JSON paths); a
// file that cannot be read or is not JSON is one issue with an empty path (syntax errors give line
// and column). Relative file names inside the study are resolved against the file's directory.
Study loadStudy(const std::filesystem::path& file);

// Same, from JSON text; `origin` names the source in messages and its directory resolves relative
// file names inside the study.
Study parseStudy(const std::string& json_text, const std::string& origin);

// The gate every study passes, also one built or changed in code (tests, benchmarks, the loops of
// campaign/): the same type, range, applicability and cross-field rules as loadStudy(), judged on
// the study's file form (toJson), so every problem names its JSON path. Throws StudyError listing
// them (file: study.source, or `study "NAME"` for a study built in code). Relative file names are
// resolved against study.source's directory (the working directory when it is empty).
void validate(const Study& study);

// The key reference of docs/study-file.md (its generated section): a Markdown table with one row
// per key (key, unit or values, range, default, when it applies, meaning), from the key table the
// loader and toJson() use.
std::string keyReference();

// The effective study in file form: file units and key names, every default filled in, only the
// keys that apply to the study's kind and models. parseStudy(toJson(s).dump(), origin) == s.
nlohmann::ordered_json toJson(const Study& study);

// What makes two studies the same study: toJson() without the keys added after results were kept
// that stand at their default (soil.contact.rolling_regularisation_fraction), so a study written
// before such a key and one that spells out its default are one study. The soil hash and a
// campaign's case identity are built on it.
nlohmann::ordered_json identityJson(const Study& study);

// The effective values with units, one "path = value unit" line each (for `demfem validate`), in
// the file's units, e.g. "/tools/0/motion/depth_mm = 18 mm".
std::string describe(const Study& study);

// Stable content hash of everything that determines the settled soil (for deposit reuse): FNV-1a
// 64 of the canonical JSON text (sorted keys, shortest round-trip numbers) of the bin, fill height,
// particle sizes, the particle and bin materials, layers, the interactions among them, the contact
// model, the deposition settings (seed, threshold, bulk density, deposition backend and threads)
// and the DEM time step settings, as identityJson() writes them. Tools, the run's DEM backend
// (dem.backend), dem.seed and dem.threads do not enter: one soil serves every backend and every
// run's core count. 16 lowercase hex digits.
// Throws std::invalid_argument for kinds without soil.
std::string soilHash(const Study& study);

// True for the kinds that simulate soil (coupled, dem-only, cone-penetration).
bool hasSoil(StudyKind kind);

// `text` with every byte that is not part of a well-formed UTF-8 sequence written as \xNN: file
// names and quoted file content can then always be printed and stored in JSON reports.
std::string validUtf8(std::string_view text);

// FNV-1a 64-bit hash of `bytes` (offset basis 14695981039346656037, prime 1099511628211), the hash
// soilHash() applies to its canonical text.
std::uint64_t fnv1a64(std::string_view bytes);

}  // namespace demfem::study

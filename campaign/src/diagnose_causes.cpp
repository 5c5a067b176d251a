#include "demfem/campaign/diagnose_causes.hpp"

#include "demfem/campaign/calibration.hpp"

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>
#include <sstream>

namespace demfem::campaign {
namespace {

using analysis::Estimate;
using analysis::Signatures;
using nlohmann::ordered_json;

std::string fixed(double v, int digits = 3) {
  std::ostringstream s;
  s.precision(digits);
  s << std::fixed << v;
  return s.str();
}

double allowance(const Estimate& e, double relative, const SignatureTolerance& t) {
  return std::max(relative, t.scatter_factor * e.std_error);
}
// A ratio beyond its tolerance from 1: +1 above, -1 below, 0 within.
int ratioSign(const Estimate& e, const SignatureTolerance& t) {
  const double a = allowance(e, t.relative, t);
  return e.value > 1 + a ? 1 : e.value < 1 - a ? -1 : 0;
}
int differenceSign(const Estimate& e, const SignatureTolerance& t) {
  const double a = allowance(e, t.damping, t);
  return e.value > a ? 1 : e.value < -a ? -1 : 0;
}

std::string weightEvidence(const Signatures& s) {
  std::string text;
  for (const auto& w : s.weight_drops)
    text += (text.empty() ? "" : "; ") + fixed(w.key.mass_kg, 3) + " kg: force x" + fixed(w.force_ratio.value) + ", deformation x" +
            fixed(w.deformation_ratio.value) + ", frequency x" + fixed(w.frequency_ratio.value) + ", damping ratio " +
            (w.damping_difference.value >= 0 ? "+" : "") + fixed(w.damping_difference.value, 4);
  return text;
}

std::string soilEvidence(const Signatures& s) {
  std::string text;
  for (const auto& b : s.soil_bins)
    text += (text.empty() ? "" : "; ") + fixed(b.key.depth_mm, 0) + " mm: force bias " + fixed(b.force_bias_percent, 1) +
            " %, end rise " + (b.end_rise_difference >= 0 ? "+" : "") + fixed(b.end_rise_difference, 2);
  if (s.force_bias_per_depth_percent_per_mm) text += "; bias trend " + fixed(*s.force_bias_per_depth_percent_per_mm, 2) + " %/mm";
  return text;
}

SignatureMatch noWeights() { return {false, "no calibration-weight comparison"}; }
SignatureMatch noSoil() { return {false, "no soil-bin comparison at two or more depths"}; }

// --- study file helpers (JSON, file units) ---

std::size_t deformableTool(const ordered_json& study, const std::string& cause) {
  const auto& tools = study.at("tools");
  for (std::size_t i = 0; i < tools.size(); ++i)
    if (tools[i].contains("fem")) return i;
  throw ArgumentError("cause '" + cause + "': the study has no deformable tool (no tools[].fem)");
}

std::string toolPointer(std::size_t tool) { return "/tools/" + std::to_string(tool); }

ParameterSpec spec(std::string pointer, double lo, double hi, bool log) {
  ParameterSpec p;
  p.pointer = std::move(pointer);
  p.lo = lo;
  p.hi = hi;
  p.log = log;
  return p;
}

// EI / L of a plate tool's free part (N m/rad), the scale of a clamp spring.
double freeBendingStiffness(const ordered_json& tool, const std::string& cause) {
  const auto& g = tool.at("geometry");
  if (g.at("kind") != "plate" || !tool.at("fem").contains("E_Pa"))
    throw ArgumentError("cause '" + cause + "': needs a plate tool with E_Pa (the spring's range is scaled by its bending stiffness)");
  const double E = tool.at("fem").at("E_Pa").get<double>();
  const double w = g.at("width_mm").get<double>() * 1e-3, t = g.at("thickness_mm").get<double>() * 1e-3;
  const double free = (g.at("length_mm").get<double>() - tool.at("constraints").at("clamp_length_mm").get<double>()) * 1e-3;
  return E * w * t * t * t / 12 / free;
}

const ordered_json& soilOf(const ordered_json& study, const std::string& cause) {
  if (!study.contains("soil")) throw ArgumentError("cause '" + cause + "': the study has no soil");
  return study.at("soil");
}

// Materials of the layers holding the tool tip at the recordings' depths (top < depth <= bottom).
std::vector<std::string> reachedLayers(const ordered_json& soil, const std::vector<double>& depths_mm) {
  std::vector<std::string> out;
  for (double d : depths_mm)
    for (const auto& layer : soil.at("layers"))
      if (layer.at("top_depth_mm").get<double>() < d && d <= layer.at("bottom_depth_mm").get<double>()) {
        const std::string m = layer.at("material");
        if (std::find(out.begin(), out.end(), m) == out.end()) out.push_back(m);
      }
  return out;
}

bool samePair(const ordered_json& materials, const std::string& a, const std::string& b) {
  return (materials[0] == a && materials[1] == b) || (materials[0] == b && materials[1] == a);
}

std::optional<std::size_t> interactionOf(const ordered_json& soil, const std::string& a, const std::string& b) {
  const auto& list = soil.at("interactions");
  for (std::size_t i = 0; i < list.size(); ++i)
    if (samePair(list[i].at("materials"), a, b)) return i;
  return std::nullopt;
}

std::string interactionPointer(std::size_t i, const char* key) { return "/soil/interactions/" + std::to_string(i) + "/" + key; }

// Splits every layer at the recordings' depths strictly inside it; each new piece gets a copy of the
// layer's material ("<material>_<n>") and copies of all the material's interactions.
ordered_json splitLayers(ordered_json study, const std::vector<double>& depths_mm) {
  ordered_json& soil = study.at("soil");
  ordered_json layers = ordered_json::array();
  std::vector<std::pair<std::string, std::string>> copies;  // (original, copy)
  for (const auto& layer : soil.at("layers")) {
    const double top = layer.at("top_depth_mm"), bottom = layer.at("bottom_depth_mm");
    std::vector<double> cuts{top};
    for (double d : depths_mm)
      if (d > top && d < bottom && d > cuts.back()) cuts.push_back(d);
    cuts.push_back(bottom);
    for (std::size_t k = 0; k + 1 < cuts.size(); ++k) {
      ordered_json piece = layer;
      piece["top_depth_mm"] = cuts[k];
      piece["bottom_depth_mm"] = cuts[k + 1];
      if (k > 0) {
        const std::string name = layer.at("material").get<std::string>() + "_" + std::to_string(k + 1);
        copies.emplace_back(layer.at("material"), name);
        piece["material"] = name;
      }
      layers.push_back(piece);
    }
  }
  soil["layers"] = layers;
  for (const auto& [original, copy] : copies)
    for (const auto& material : ordered_json(soil.at("materials")))
      if (material.at("name") == original) {
        ordered_json m = material;
        m["name"] = copy;
        soil["materials"].push_back(m);
      }
  const auto originalOf = [&](const std::string& name) {
    for (const auto& [o, c] : copies)
      if (c == name) return o;
    return name;
  };
  std::vector<std::string> names;
  for (const auto& m : soil.at("materials")) names.push_back(m.at("name"));
  const ordered_json original_interactions = soil.at("interactions");
  ordered_json interactions = ordered_json::array();
  for (std::size_t i = 0; i < names.size(); ++i)
    for (std::size_t j = i; j < names.size(); ++j)
      for (const auto& entry : original_interactions)
        if (samePair(entry.at("materials"), originalOf(names[i]), originalOf(names[j]))) {
          ordered_json e = entry;
          e["materials"] = {names[i], names[j]};
          interactions.push_back(e);
        }
  soil["interactions"] = interactions;
  return study;
}

// --- the causes ---

Cause youngModulus() {
  Cause c;
  c.id = "young_modulus";
  c.description = "Young's modulus of the tool (tools[].fem.E_Pa)";
  c.expected_signature = "frequency and deformation off together (f^2 x d about 1 for a pure stiffness error), force per weight unchanged";
  c.match = [](const Signatures& s, const SignatureTolerance& t) {
    if (s.weight_drops.empty()) return noWeights();
    bool stiffness = false;
    for (const auto& w : s.weight_drops) stiffness |= ratioSign(w.deformation_ratio, t) != 0 || ratioSign(w.frequency_ratio, t) != 0;
    return SignatureMatch{stiffness, weightEvidence(s)};
  };
  c.extend = [id = c.id](const ordered_json& study, const std::vector<double>&) {
    const std::size_t tool = deformableTool(study, id);
    const auto& fem = study.at("tools")[tool].at("fem");
    if (!fem.contains("E_Pa")) throw ArgumentError("cause '" + id + "': the tool's matrices are given, it has no E_Pa");
    const double E = fem.at("E_Pa");
    return Extension{study, {spec(toolPointer(tool) + "/fem/E_Pa", 0.5 * E, 2 * E, true)}};
  };
  return c;
}

Cause clampCompliance() {
  Cause c;
  c.id = "clamp_compliance";
  c.description = "a compliant clamp: rotational spring at the clamp edge (tools[].constraints.clamp_rotational_stiffness_Nm_per_rad)";
  c.expected_signature = "load-cell force per weight lower (the clamp carries less moment), deformation larger, frequency lower";
  c.match = [](const Signatures& s, const SignatureTolerance& t) {
    if (s.weight_drops.empty()) return noWeights();
    bool lower = false;
    for (const auto& w : s.weight_drops) lower |= ratioSign(w.force_ratio, t) < 0;
    return SignatureMatch{lower, weightEvidence(s)};
  };
  c.extend = [id = c.id](const ordered_json& study, const std::vector<double>&) {
    const std::size_t tool = deformableTool(study, id);
    const double scale = freeBendingStiffness(study.at("tools")[tool], id);
    ordered_json extended = study;
    auto& constraints = extended.at("tools")[tool].at("constraints");
    // Starts nearly rigid (1000 EI/L); the range reaches a tenth of the free part's EI/L.
    if (!constraints.contains("clamp_rotational_stiffness_Nm_per_rad")) constraints["clamp_rotational_stiffness_Nm_per_rad"] = 1000 * scale;
    return Extension{extended,
                     {spec(toolPointer(tool) + "/constraints/clamp_rotational_stiffness_Nm_per_rad", 0.1 * scale, 1000 * scale, true)}};
  };
  return c;
}

Cause massDamping() {
  Cause c;
  c.id = "mass_damping";
  c.description = "mass-proportional Rayleigh damping, the beta term of Eq (4) (tools[].fem.beta_per_s)";
  c.expected_signature = "measured damping ratio higher, by more at the heavy weight (lower frequency: zeta = beta / 2 omega)";
  c.match = [](const Signatures& s, const SignatureTolerance& t) {
    if (s.weight_drops.empty()) return noWeights();
    const bool heavier = differenceSign(s.weight_drops.back().damping_difference, t) > 0;
    const bool trend = !s.weight_relations.defined || s.weight_relations.damping_difference_change > -t.damping;
    return SignatureMatch{heavier && trend, weightEvidence(s)};
  };
  c.extend = [id = c.id](const ordered_json& study, const std::vector<double>&) {
    const std::size_t tool = deformableTool(study, id);
    // Up to 20 1/s: a damping ratio of 0.6 at 2.6 Hz, far above any clamped plastic tool's.
    return Extension{study, {spec(toolPointer(tool) + "/fem/beta_per_s", 0.0, 20.0, false)}};
  };
  return c;
}

// One channel's calibration factor: `key` of tools[].sensors added at 1, 0.7-1.4.
Cause sensorGain(const std::string& channel, const char* key) {
  Cause c;
  c.id = channel + "_sensor_gain";
  c.description = "a calibration-factor error of the " + channel + " channel (tools[].sensors." + key + ")";
  c.expected_signature = "the " + channel + " channel's steady ratio off by the same factor at every weight, frequency and damping unchanged";
  const bool force = channel == "force";
  c.match = [force](const Signatures& s, const SignatureTolerance& t) {
    if (s.weight_drops.empty()) return noWeights();
    bool steady = false;
    for (const auto& w : s.weight_drops) steady |= ratioSign(force ? w.force_ratio : w.deformation_ratio, t) != 0;
    return SignatureMatch{steady, weightEvidence(s)};
  };
  c.extend = [id = c.id, key](const ordered_json& study, const std::vector<double>&) {
    const std::size_t tool = deformableTool(study, id);
    ordered_json extended = study;
    auto& sensors = extended.at("tools")[tool]["sensors"];
    if (!sensors.contains(key)) sensors[key] = 1.0;
    return Extension{extended, {spec(toolPointer(tool) + "/sensors/" + key, 0.7, 1.4, false)}};
  };
  return c;
}

// Both Rayleigh terms of Eq (4) free: the stiffness term over 0.01-10 x the study's (log), the mass
// term 0-20 1/s. The baseline's alpha_s (0.5-2 x) cannot move the split between the weights.
Cause dampingForm() {
  Cause c;
  c.id = "damping_form";
  c.description = "the form of the damping: both Rayleigh terms of Eq (4) (tools[].fem.alpha_s and beta_per_s) beyond the nominal alpha_s";
  c.expected_signature = "damping ratio off differently at the two weights (zeta = alpha omega / 2 + beta / 2 omega), statics unchanged";
  c.match = [](const Signatures& s, const SignatureTolerance& t) {
    if (s.weight_drops.empty()) return noWeights();
    bool damping = false;
    for (const auto& w : s.weight_drops) damping |= differenceSign(w.damping_difference, t) != 0;
    return SignatureMatch{damping, weightEvidence(s)};
  };
  c.extend = [id = c.id](const ordered_json& study, const std::vector<double>&) {
    const std::size_t tool = deformableTool(study, id);
    const double alpha = study.at("tools")[tool].at("fem").at("alpha_s").get<double>();
    if (!(alpha > 0)) throw ArgumentError("cause '" + id + "': needs alpha_s > 0 (its range is scaled by the study's)");
    const std::string base = toolPointer(tool) + "/fem/";
    return Extension{study, {spec(base + "alpha_s", 0.01 * alpha, 10 * alpha, true), spec(base + "beta_per_s", 0.0, 20.0, false)}};
  };
  return c;
}

// Mass on the pan rows the study does not have (weight_drop.added_mass_kg, its weight tared).
Cause addedMass() {
  Cause c;
  c.id = "added_mass";
  c.description = "unmodelled mass at the tip: pan, hook or a sensor hanging there before the weight (weight_drop.added_mass_kg)";
  c.expected_signature = "frequency lower, by more at the light weight, statics and force per weight unchanged";
  c.match = [](const Signatures& s, const SignatureTolerance& t) {
    if (s.weight_drops.empty()) return noWeights();
    bool lower = false;
    for (const auto& w : s.weight_drops) lower |= ratioSign(w.frequency_ratio, t) < 0;
    return SignatureMatch{lower, weightEvidence(s)};
  };
  c.extend = [id = c.id](const ordered_json& study, const std::vector<double>&) {
    if (!study.contains("weight_drop")) throw ArgumentError("cause '" + id + "': the study has no weight_drop");
    ordered_json extended = study;
    auto& drop = extended.at("weight_drop");
    if (!drop.contains("added_mass_kg")) drop["added_mass_kg"] = 0.0;
    // Up to the study's weight: a pan as heavy as the weight it carries.
    return Extension{extended, {spec("/weight_drop/added_mass_kg", 0.0, drop.at("mass_kg").get<double>(), false)}};
  };
  return c;
}

// The soil causes' quantities: the draught's (and deformation's) level over the window.
std::vector<std::string> windowMeans() { return {"window_mean_force_N", "window_mean_deformation_mm"}; }

Cause layeredSoil() {
  Cause c;
  c.id = "layered_soil";
  c.domain = analysis::CaseKind::SoilBin;
  c.judged_on = windowMeans();
  c.description =
      "depth-dependent soil strength: static friction per layer (Section 2.10.2), layers split at the recordings' depths but the "
      "two deepest";
  c.expected_signature = "a draught bias that changes with depth";
  c.match = [](const Signatures& s, const SignatureTolerance& t) {
    if (s.soil_bins.size() < 2 || !s.force_bias_per_depth_percent_per_mm) return noSoil();
    const double range = s.soil_bins.back().key.depth_mm - s.soil_bins.front().key.depth_mm;
    return SignatureMatch{std::abs(*s.force_bias_per_depth_percent_per_mm) * range > 100 * t.relative, soilEvidence(s)};
  };
  c.extend = [id = c.id](const ordered_json& study, const std::vector<double>& depths_mm) {
    soilOf(study, id);
    // The deepest depth shares the layer of the next shallower one (as the paper's 42 mm runs share
    // the 30 mm layer): a fit that leaves it out still predicts it. Two depths: split at the shallower.
    std::vector<double> cuts(depths_mm.begin(), depths_mm.end() - std::min<std::ptrdiff_t>(2, std::ssize(depths_mm)));
    if (cuts.empty() && !depths_mm.empty()) cuts.push_back(depths_mm.front());
    const ordered_json extended = splitLayers(study, cuts);
    Extension e{extended, {}};
    for (const std::string& m : reachedLayers(extended.at("soil"), depths_mm))
      if (auto i = interactionOf(extended.at("soil"), m, m))
        e.parameters.push_back(spec(interactionPointer(*i, "static_friction"), 0.05, 1.5, false));
    return e;
  };
  return c;
}

Cause cohesion() {
  Cause c;
  c.id = "cohesion";
  c.domain = analysis::CaseKind::SoilBin;
  c.judged_on = windowMeans();
  c.description = "particle cohesion (soil.interactions[].cohesion_J_m3 of the layers reached)";
  c.expected_signature = "a draught bias of the same sign at every depth";
  c.match = [](const Signatures& s, const SignatureTolerance& t) {
    if (s.soil_bins.empty()) return noSoil();
    int sign = 0;
    bool same = true;
    for (const auto& b : s.soil_bins) {
      const int here = b.force_bias_percent > 100 * t.relative ? 1 : b.force_bias_percent < -100 * t.relative ? -1 : 0;
      same = same && here != 0 && (sign == 0 || here == sign);
      sign = here;
    }
    return SignatureMatch{same, soilEvidence(s)};
  };
  c.extend = [id = c.id](const ordered_json& study, const std::vector<double>& depths_mm) {
    soilOf(study, id);
    ordered_json extended = study;
    ordered_json& soil = extended.at("soil");
    if (soil.at("contact").at("cohesion") == "none") {  // switch the law on with every pair at zero
      const bool liggghts = extended.contains("dem") && extended.at("dem").value("backend", "builtin") == "liggghts";
      soil["contact"]["cohesion"] = liggghts ? "sjkr" : "edem-linear";
      for (auto& entry : soil.at("interactions")) entry["cohesion_J_m3"] = 0.0;
    }
    Extension e{extended, {}};
    for (const std::string& m : reachedLayers(soil, depths_mm))
      if (auto i = interactionOf(soil, m, m)) e.parameters.push_back(spec(interactionPointer(*i, "cohesion_J_m3"), 0.0, 3e5, false));
    return e;
  };
  return c;
}

Cause endWall() {
  Cause c;
  c.id = "end_wall";
  c.domain = analysis::CaseKind::SoilBin;
  c.judged_on = windowMeans();
  c.description = "the bin's end wall: particle-wall friction (soil.interactions[] with the bin material)";
  c.expected_signature = "a different end-of-stroke rise of the draught (the approaching wall)";
  c.match = [](const Signatures& s, const SignatureTolerance& t) {
    if (s.soil_bins.empty()) return noSoil();
    bool rise = false;
    for (const auto& b : s.soil_bins) rise |= std::abs(b.end_rise_difference) > 5 * t.relative;
    return SignatureMatch{rise, soilEvidence(s)};
  };
  c.extend = [id = c.id](const ordered_json& study, const std::vector<double>& depths_mm) {
    const ordered_json& soil = soilOf(study, id);
    const std::string bin = soil.at("bin").at("material");
    Extension e{study, {}};
    for (const std::string& m : reachedLayers(soil, depths_mm))
      if (auto i = interactionOf(soil, m, bin)) e.parameters.push_back(spec(interactionPointer(*i, "static_friction"), 0.05, 1.0, false));
    return e;
  };
  return c;
}

Cause toolFriction() {
  Cause c;
  c.id = "tool_friction";
  c.domain = analysis::CaseKind::SoilBin;
  c.judged_on = windowMeans();
  c.description = "particle-tool friction (soil.interactions[] of the layers reached with the tool's dem_material)";
  c.expected_signature = "a draught bias of the same sign at every depth, growing with the tool's wetted face";
  c.match = [](const Signatures& s, const SignatureTolerance& t) {
    if (s.soil_bins.empty()) return noSoil();
    bool bias = false;
    for (const auto& b : s.soil_bins) bias |= std::abs(b.force_bias_percent) > 100 * t.relative;
    return SignatureMatch{bias, soilEvidence(s)};
  };
  c.extend = [id = c.id](const ordered_json& study, const std::vector<double>& depths_mm) {
    const ordered_json& soil = soilOf(study, id);
    Extension e{study, {}};
    for (const auto& tool : study.at("tools")) {
      if (!tool.contains("dem_material")) continue;
      for (const std::string& m : reachedLayers(soil, depths_mm))
        if (auto i = interactionOf(soil, m, tool.at("dem_material")))
          e.parameters.push_back(spec(interactionPointer(*i, "static_friction"), 0.05, 1.0, false));
    }
    return e;
  };
  return c;
}

}  // namespace

const std::vector<Cause>& causeCatalogue() {
  static const std::vector<Cause> catalogue{youngModulus(),  clampCompliance(),
                                            massDamping(),   dampingForm(),
                                            addedMass(),     sensorGain("force", "force_gain"),
                                            sensorGain("deformation", "deformation_gain"),
                                            layeredSoil(),   cohesion(),
                                            endWall(),       toolFriction()};
  return catalogue;
}

const Cause& findCause(const std::string& id) {
  std::string ids;
  for (const Cause& c : causeCatalogue()) {
    if (c.id == id) return c;
    ids += (ids.empty() ? "" : ", ") + c.id;
  }
  throw ArgumentError("unknown cause '" + id + "' (causes: " + ids + ")");
}

std::vector<ParameterSpec> baselineParameters(const ordered_json& study, const std::string& origin,
                                              const std::vector<analysis::Recording>& recordings, analysis::CaseKind domain) {
  switch (domain) {
    case analysis::CaseKind::CalibrationWeight: {
      const std::size_t tool = deformableTool(study, "baseline");
      const auto& fem = study.at("tools")[tool].at("fem");
      if (!fem.contains("E_Pa")) throw ArgumentError("baseline: the tool's matrices are given, it has no E_Pa (give --baseline-fit)");
      const double E = fem.at("E_Pa"), alpha = fem.at("alpha_s");
      const std::string base = toolPointer(tool) + "/fem/";
      return {spec(base + "E_Pa", E / 1.1, E * 1.1, true),
              alpha > 0 ? spec(base + "alpha_s", alpha / 2, alpha * 2, true) : spec(base + "alpha_s", 1e-6, 1e-2, true)};
    }
    case analysis::CaseKind::SoilBin: {
      std::vector<ParameterSpec> out;
      for (const Stage& stage : layeredSoilPreset(study, origin, recordings))
        out.insert(out.end(), stage.parameters.begin(), stage.parameters.end());
      return out;
    }
  }
  throw ArgumentError("baseline: unknown case kind");
}

}  // namespace demfem::campaign
